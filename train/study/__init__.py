"""`simgen-train study`: the paper's tables from a scenario (run), their Markdown and CSV (report,
seeds) and the tracklet filter chosen for each tracker (tracklet_filter)."""
