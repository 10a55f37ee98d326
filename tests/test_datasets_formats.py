"""The formats registry: each name gives its plug-in, an unknown name is one line."""

from __future__ import annotations

import pytest

from simgen.datasets.formats import FORMATS, dataset_format
from simgen.datasets.formats.base import DatasetFormat
from simgen.errors import UserError


@pytest.mark.parametrize("name", FORMATS)
def test_every_registered_name_gives_the_format_of_that_name(name):
    plugin = dataset_format(name)
    assert isinstance(plugin, DatasetFormat) and plugin.name == name


def test_an_unknown_format_is_one_line_naming_the_formats():
    with pytest.raises(UserError) as error:
        dataset_format("las")
    assert (
        str(error.value) == "unknown dataset format 'las' (choose from parquet, kitti, kitti_tracking, openpcdet, mcap)"
    )
