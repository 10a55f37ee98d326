"""What the tests share, imported as `tests.support.<module>` (benchmarks and scripts/measure_box_margins.py
import some of it too; product code never does): paths of the repository and its committed fixtures here,
helpers by subject in the modules beside this one."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FIXTURES = ROOT / "tests" / "fixtures"
MOTION_FIXTURE = FIXTURES / "motion_smoke.parquet"
