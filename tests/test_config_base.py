"""A detector config may name a `base` config and change only some keys (train.config.load_config)."""

from __future__ import annotations

import pytest
import yaml

from simgen.errors import UserError
from tests.support import ROOT
from train.config import MAX_BASES, load_config


def _write(path, document):
    path.write_text(yaml.safe_dump(document))
    return path


def test_a_config_with_a_base_is_the_base_with_its_keys_laid_over(tmp_path):
    compact = load_config(ROOT / "train/configs/late.yaml")
    child = _write(tmp_path / "wide.yaml", {"base": str(ROOT / "train/configs/late.yaml"), "name": "wide",
                                            "data": {"point_range_m": [-56.0, -38.0, -0.1, 56.0, 38.0, 2.5]},
                                            "train": {"iterations": 7}})
    wide = load_config(child)
    assert wide.name == "wide" and wide.data.point_range_m == (-56.0, -38.0, -0.1, 56.0, 38.0, 2.5)
    assert wide.train.iterations == 7 and wide.train.batch_size == compact.train.batch_size  # merged key by key
    assert wide.model == compact.model and wide.data.pillar_size_m == compact.data.pillar_size_m


def test_a_base_is_found_from_the_configs_own_folder(tmp_path):
    (tmp_path / "sub").mkdir()
    _write(tmp_path / "parent.yaml", yaml.safe_load((ROOT / "train/configs/single.yaml").read_text()))
    child = _write(tmp_path / "sub" / "child.yaml", {"base": "../parent.yaml", "seed": 3})
    assert load_config(child).seed == 3


@pytest.mark.parametrize("base", [7, "late.txt", "missing.yaml", "self"])
def test_a_bad_base_is_one_line_naming_the_file(tmp_path, base):
    path = tmp_path / "bad.yaml"
    _write(path, {"base": "bad.yaml" if base == "self" else base, "name": "bad"})  # "self": a cycle
    with pytest.raises(UserError) as error:
        load_config(path)
    message = str(error.value)
    assert "\n" not in message and ("bad.yaml" in message or "missing.yaml" in message)
    if base == "self":
        assert str(MAX_BASES) in message
