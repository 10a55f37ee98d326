"""The pipeline: one clip from motion to labelled frames (`clip`), and a whole dataset's clips, locked and
resumable (`dataset_run`): its jobs (`jobs`), their order (`schedule`), where they run (`executor`:
`local_pool`, `ray_cluster`), the run state in the output directory (`run_state`) and Arrow's memory
settings (`memory`)."""
