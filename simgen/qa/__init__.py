"""Quality assurance of scan patterns and datasets: checks with pass / fail limits
(`tolerances`), the numbers behind them (`pattern`, `dataset`, `labels`, `integrity`), plots
(`plots`) and the report that shows them (`report`)."""
