"""The pipeline: one clip from motion to labelled frames (`clip`), and a whole dataset's clips on local
processes or Ray tasks, locked and resumable (`dataset_run`)."""
