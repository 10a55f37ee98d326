"""Hostile input, generated: scenarios (every section, custom sensors, the YAML itself) and manifests
and datasets, each refused in one line with exit code 2, nothing written, in bounded memory and time.

Most cases run in this process through the CLI's `main` (fast); a handful run as real processes,
their peak memory measured. The counts in docs/reliability.md are the constants asserted here.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

import simgen.datasets as datasets
from simgen.cli import main
from simgen.datasets import FORMATS
from simgen.datasets.manifest import MANIFEST_NAME
from simgen.errors import UserError
from simgen.validation import MAX_YAML_BYTES, MAX_YAML_DEPTH, MAX_YAML_NODES
from tests.support import ROOT
from tests.support.datasets import sample_clips, write_dataset
from tests.support.hostile import (
    MAX_GROWTH_BYTES,
    SETTINGS,
    assert_one_line_refusal,
    measured_process,
    peak_bytes,
    refuse_generated,
    run_main,
)

HOSTILE_SCENARIOS = 1000
CORRUPT_MANIFESTS = 500
CORRUPT_DATA_FILES = 100
MAX_PROCESS_BYTES = 1 << 30

BASE = {"name": "hostile", "seed": 3, "motion": {"level": "11_vs_11_stochastic", "frames": 30, "capture_hz": 10}}
PRESETS = ["mid40-risley", "mid40-rose", "mid40-replay", "mid70-replay", "mid100-risley", "mid100-rose"]


def _run(*arguments) -> tuple[int, str, str]:
    """`simgen ARGUMENTS` in this process: exit code, stdout, stderr."""
    return run_main(main, *arguments)


# --- scenarios ------------------------------------------------------------------------------------

LETTERS = st.text(alphabet="qwxz", min_size=1, max_size=6)  # no number, bool or null YAML or pydantic would read
WRONG_TYPE = st.one_of(LETTERS, st.lists(st.integers(), min_size=1, max_size=3), st.just({"k": 1}),
                       st.just(float("nan")), st.just(float("inf")), st.just(float("-inf")))


def _outside(lo: float, hi: float, integer: bool, optional: bool = False):
    """Values a field bounded to [lo, hi] refuses."""
    below = st.floats(min_value=1e-3, max_value=1e12).map(lambda d: lo - d)
    above = st.floats(min_value=1e-3, max_value=1e12).map(lambda d: hi + d)
    if integer:
        below, above = below.map(lambda v: int(v) - 1), above.map(lambda v: int(v) + 1)
        fractional = st.integers(int(lo), int(min(hi, lo + 1000)) - 1).map(lambda v: v + 0.5)
        return st.one_of(below, above, fractional, WRONG_TYPE, *([] if optional else [st.none()]))
    return st.one_of(below, above, WRONG_TYPE, *([] if optional else [st.none()]))


BOOL_BAD = st.one_of(LETTERS, st.integers(2, 10**6), st.lists(st.booleans(), min_size=1), st.just({"k": True}))
NAME_BAD = st.one_of(
    st.text(min_size=1, max_size=10).map(lambda s: s + " /"), st.integers(), st.lists(LETTERS, min_size=1), st.none()
)
FIELDS = {  # (section, key): bad values
    ("motion", "frames"): _outside(1, 1_000_000, True),
    ("motion", "capture_hz"): st.one_of(
        st.integers(-1000, 1000).filter(lambda v: v not in (10, 20, 25, 50, 100)), WRONG_TYPE
    ),
    ("motion", "skip_s"): _outside(0, 3600, False),
    ("motion", "left_difficulty"): _outside(0, 1, False, optional=True),
    ("motion", "right_difficulty"): _outside(0, 1, False, optional=True),
    ("motion", "level"): NAME_BAD,
    ("scene", "goals"): BOOL_BAD,
    ("scene", "surroundings"): BOOL_BAD,
    ("scene", "net_transmission"): _outside(0, 1, False),
    ("scan", "frame_rate_hz"): _outside(1e-9, 100, False),
    ("scan", "density"): _outside(1e-9, 64, False),
    ("scan", "sweeps_per_frame"): _outside(1, 16, True),
    ("scan", "frames"): _outside(1, 1_000_000, True, optional=True),
    ("noise", "range_sigma_m"): _outside(0, 1, False),
    ("noise", "angle_sigma_deg"): _outside(0, 1, False),
    ("noise", "subrays"): _outside(1, 16, True),
    ("noise", "min_range_m"): _outside(0, 50, False),
    ("noise", "max_range_at_10pct_m"): _outside(1e-9, 1000, False),
    ("noise", "dropout"): _outside(0, 0.999, False),
    ("noise", "enabled"): BOOL_BAD,
    ("noise", "divergence_deg"): st.one_of(
        st.tuples(_outside(0, 10, False).filter(lambda v: v is not None), st.floats(0, 10)).map(list),
        st.lists(st.floats(0, 10), max_size=5).filter(lambda v: len(v) != 2),
        WRONG_TYPE.filter(lambda v: not isinstance(v, list)),
    ),
    ("dataset", "clips"): _outside(1, 100_000, True),
    ("dataset", "format"): st.one_of(LETTERS, st.integers(), st.none()),
    ("", "seed"): _outside(0, 2**31 - 1, True),
    ("", "name"): NAME_BAD,
    ("", "description"): st.one_of(st.integers(), st.lists(LETTERS, min_size=1), st.just({"k": 1})),
}
POSE = {"x": (-200, 200), "y": (-200, 200), "z": (0, 100), "roll": (-180, 180), "pitch": (-90, 90), "yaw": (-360, 360)}
HEAD = {"shots_per_s": (1e-9, 20_000_000), "fov_deg": (1e-9, 179.999), "yaw_deg": (-360, 360), "pitch_deg": (-90, 90),
        "time_offset_s": (0, 1e6)}
PARAMS = {
    "risley": st.one_of(
        st.fixed_dictionaries({"index": _outside(1.000001, 4, False, optional=True)}),
        st.fixed_dictionaries({"wedge_deg": st.tuples(_outside(1e-9, 44.999, False), st.just(18.0)).map(list)}),
        st.fixed_dictionaries({"rpm": st.lists(st.floats(-1e5, 1e5), max_size=4).filter(lambda v: len(v) != 2)}),
        st.fixed_dictionaries(
            {"phase_deg": st.one_of(LETTERS, st.lists(st.floats(0, 1), min_size=3, max_size=4), st.just({"k": 1}))}
        ),
    ),
    "rose": st.one_of(
        st.fixed_dictionaries({"k": _outside(1e-9, 1000, False, optional=True)}),
        st.fixed_dictionaries({"petals_per_frame": _outside(1e-9, 10_000, False, optional=True)}),
        st.fixed_dictionaries({"theta0_hz": _outside(-1e6, 1e6, False, optional=True)}),
    ),
}
REPLAY_FILES = ["/etc/passwd", "/etc/shadow", "/dev/zero", "/proc/self/environ", "../" * 8 + "etc/hostname", "/",
                "link_out.npz", "fake.npz", "fake.csv", "absent.npz", "folder.npz", "bomb.npz", "nul\0byte.npz"]


@st.composite
def _custom_sensor_case(draw) -> tuple[str, dict]:
    data = json.loads(json.dumps(BASE))
    kind = draw(st.sampled_from(["head field", "head type", "heads type", "pattern", "like", "no pattern", "params",
                                 "params type", "unknown param", "replay file", "name", "preset name", "duplicate",
                                 "heads count"]))
    head: object = {"pattern": draw(st.sampled_from(["risley", "rose"]))}
    sensor: dict = {"name": "custom", "heads": [head]}
    if kind == "head field":
        key = draw(st.sampled_from(sorted(HEAD)))
        head[key] = draw(_outside(*HEAD[key], False, optional=True))
    elif kind == "head type":
        sensor["heads"] = [draw(st.one_of(st.integers(), LETTERS, st.lists(st.integers(), max_size=2), st.none()))]
    elif kind == "heads type":
        sensor["heads"] = draw(st.one_of(st.integers(), LETTERS, st.just({"pattern": "rose"}), st.none()))
    elif kind == "pattern":
        head["pattern"] = draw(st.one_of(LETTERS, st.integers(), st.none().map(lambda _: ["rose"])))
    elif kind == "like":
        sensor["heads"] = [{"like": draw(st.one_of(LETTERS, st.integers(), st.just("custom")))}]
    elif kind == "no pattern":
        sensor["heads"] = [
            draw(st.fixed_dictionaries({}, optional={"fov_deg": st.floats(1, 90), "yaw_deg": st.floats(-10, 10)}))
        ]
    elif kind == "params":
        head["params"] = draw(PARAMS[head["pattern"]])
    elif kind == "params type":
        head["params"] = draw(st.one_of(st.integers(), LETTERS, st.lists(st.integers(), min_size=1)))
    elif kind == "unknown param":
        head["params"] = {draw(LETTERS.map(lambda s: "bogus_" + s)): 1.0}
    elif kind == "replay file":
        sensor["heads"] = [{"pattern": "replay", "params": {"file": draw(st.sampled_from(REPLAY_FILES))}}]
    elif kind == "name":
        sensor["name"] = draw(NAME_BAD.filter(lambda v: v is not None))
    elif kind == "preset name":
        sensor["name"] = draw(st.sampled_from(PRESETS))
    elif kind == "duplicate":
        data["custom_sensors"] = [sensor, dict(sensor)]
    else:
        sensor["heads"] = [] if draw(st.booleans()) else [{"pattern": "rose"}] * draw(st.integers(33, 64))
    data.setdefault("custom_sensors", [sensor])
    if draw(st.booleans()):  # used by a sensor, or only declared
        data["sensors"] = [{"preset": "custom" if isinstance(sensor["name"], str) else "mid40-rose"}]
    return f"custom_sensors: {kind}", data


@st.composite
def _cross_field_case(draw) -> tuple[str, dict]:
    data = json.loads(json.dumps(BASE))
    kind = draw(st.sampled_from(["ranges", "no frames", "shot budget", "frame memory", "scan frames", "kitti frames",
                                 "sensors", "unknown preset"]))
    if kind == "ranges":
        low = draw(st.floats(0.01, 50))
        data["noise"] = {"min_range_m": low, "max_range_at_10pct_m": draw(st.floats(0.001, low))}
    elif kind == "no frames":
        data["motion"].update(frames=draw(st.integers(1, 5)), capture_hz=100)
        data["scan"] = {"frame_rate_hz": draw(st.floats(1e-6, 10))}
    elif kind == "shot budget":
        sensors = draw(st.integers(2, 16))
        density = draw(st.floats(20_000_000 / (sensors * 300_000) * 1.001, 64))
        data["sensors"] = [{"name": f"s{i}", "preset": "mid100-risley"} for i in range(sensors)]
        data["scan"] = {"density": density}
    elif kind == "frame memory":
        data["scan"] = {"density": 64, "frame_rate_hz": draw(st.floats(0.5, 2))}
        data["noise"] = {"subrays": draw(st.integers(4, 16))}
        data["sensors"] = [{"preset": "mid100-risley"}]
    elif kind == "scan frames":
        data["scan"] = {"frames": draw(st.integers(30, 1_000_000))}
    elif kind == "kitti frames":
        data["motion"]["frames"] = draw(st.integers(10_002, 1_000_000))
        data["dataset"] = {"format": draw(st.sampled_from(["kitti", "kitti_tracking", "openpcdet"]))}
    elif kind == "sensors":
        data["sensors"] = draw(
            st.one_of(
                st.just([]),
                st.integers(17, 40).map(lambda n: [{"name": f"s{i}"} for i in range(n)]),
                st.integers(),
                LETTERS,
            )
        )
    else:
        data["sensors"] = [{"preset": draw(LETTERS)}]
    if kind not in ("sensors",) and draw(st.booleans()) and "sensors" not in data:
        key = draw(st.sampled_from(sorted(POSE)))
        data["sensors"] = [{"pose": {key: draw(st.floats(*POSE[key]))}}]
    return f"cross-field: {kind}", data


@st.composite
def _field_case(draw) -> tuple[str, dict]:
    data = json.loads(json.dumps(BASE))
    kind = draw(st.sampled_from(["value", "pose", "unknown key", "section type"]))
    if kind == "value":
        section, key = draw(st.sampled_from(sorted(FIELDS)))
        value = draw(FIELDS[(section, key)])
        (data.setdefault(section, {}) if section else data)[key] = value
        return f"field {section or '(top)'}.{key}", data
    if kind == "pose":
        key = draw(st.sampled_from(sorted(POSE)))
        data["sensors"] = [{"pose": {key: draw(_outside(*POSE[key], False))}}]
        return "field sensors.pose", data
    section = draw(st.sampled_from(["motion", "scene", "scan", "noise", "dataset", ""]))
    if kind == "unknown key":
        (data.setdefault(section, {}) if section else data)[draw(LETTERS.map(lambda s: "unknown_" + s))] = 1
    else:
        data[section or "motion"] = draw(st.one_of(st.integers(), LETTERS, st.lists(st.integers(), min_size=1)))
    return f"field: {kind}", data


def _dump(data: dict) -> str:
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


@st.composite
def _yaml_case(draw) -> tuple[str, bytes]:
    """Documents refused by the YAML reader itself, whatever the schema."""
    kind = draw(st.sampled_from(["laughs", "deep", "duplicate", "recursive", "oversize", "malformed", "not a mapping",
                                 "tag", "big integer", "not UTF-8", "control character"]))
    base = _dump(BASE)
    if kind == "laughs":
        width = draw(st.integers(4, 12))
        levels = next(n for n in range(1, 40) if width**n > MAX_YAML_NODES) + draw(st.integers(0, 3))
        lines = [f"l0: &l0 [{', '.join(['lol'] * width)}]"]
        lines += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * width)}]" for i in range(1, levels)]
        where = draw(st.sampled_from(["top", "custom_sensors"]))
        if where == "top":
            text = base + "\n".join(lines) + "\n"
        else:
            anchors = "\n".join("  " + line for line in lines)
            text = (
                base
                + f"bombs:\n{anchors}\ncustom_sensors:\n"
                f"  - {{name: c, heads: [{{pattern: rose, params: {{k: *l{levels - 1}}}}}]}}\n"
            )
    elif kind == "deep":
        depth = draw(st.integers(MAX_YAML_DEPTH + 1, 20_000))
        opening, closing = ("[", "]") if draw(st.booleans()) else ("{a: ", "}")
        text = (
            base
            + f"{draw(st.sampled_from(['motion', 'custom_sensors', 'extra']))}: "
            + opening * depth
            + "1" * (opening == "{a: ")
            + closing * depth
            + "\n"
        )
    elif kind == "duplicate":
        section = draw(st.sampled_from(["seed", "motion", "name"]))
        text = base + (f"{section}: 4\n" if section != "motion" else "motion:\n  frames: 3\n  frames: 4\n")
    elif kind == "recursive":
        text = base + draw(st.sampled_from(["loop: &a [1, *a]\n", "loop: &a {k: *a}\n", "loop: &a [[[*a]]]\n"]))
    elif kind == "oversize":
        text = base + "description: '" + "x" * (MAX_YAML_BYTES + draw(st.integers(1, 4096))) + "'\n"
    elif kind == "malformed":
        text = base + draw(
            st.sampled_from(["motion: [1, 2\n", "name: 'open\n", "\tseed: 1\n", "seed: 1: 2\n", "- a\nb: c\n", "{{{\n"])
        )
    elif kind == "not a mapping":
        text = draw(st.sampled_from(["- a\n- b\n", "just a string\n", "42\n", "", "~\n", "---\n...\n", "[]\n"]))
    elif kind == "tag":
        text = base + draw(
            st.sampled_from(
                ["x: !!python/object/apply:os.system ['true']\n", "x: !!python/name:os.system\n", "x: !custom 1\n"]
            )
        )
    elif kind == "big integer":
        text = base.replace("seed: 3", "seed: " + "9" * draw(st.integers(4301, 50_000)))
    elif kind == "not UTF-8":
        position = draw(st.integers(0, len(base)))
        return f"yaml: {kind}", base[:position].encode() + draw(
            st.sampled_from([b"\xff", b"\xfe\xff", b"\xc3\x28", b"\x80"])
        ) + base[position:].encode()
    else:
        text = base + "description: " + draw(st.sampled_from(["\x00", "\x07", "\x1b[31m", "\ufffe"])) + "\n"
    return f"yaml: {kind}", text.encode()


HOSTILE = st.one_of(
    _yaml_case(),
    _field_case().map(lambda c: (c[0], _dump(c[1]).encode())),
    _custom_sensor_case().map(lambda c: (c[0], _dump(c[1]).encode())),
    _cross_field_case().map(lambda c: (c[0], _dump(c[1]).encode())),
)


def _replay_folder(folder: Path) -> None:
    """Files a replay head may name that must all be refused: links out, fakes, a folder, a zip bomb."""
    import zipfile

    (folder / "link_out.npz").symlink_to("/etc/passwd")
    (folder / "fake.npz").write_text("root:x:0:0:root:/root:/bin/bash\n")
    (folder / "fake.csv").write_text("secret,password,here\nroot,x,0\n")
    (folder / "folder.npz").mkdir()
    with zipfile.ZipFile(folder / "bomb.npz", "w", zipfile.ZIP_DEFLATED) as bomb:
        bomb.writestr("t_s.npy", b"\0" * (80 << 20))  # 80 MB that compress to ~80 KB


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_generated_hostile_scenarios_are_refused_in_one_line(tmp_path):
    _replay_folder(tmp_path)
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text("")
    before = _listing(tmp_path)

    def prepare(case):
        kind, document = case
        scenario.write_bytes(document)

        def refusal():
            code, out, err = _run("validate", scenario)
            assert "root:x:0:0" not in err and "password" not in err  # a replay file's content is never echoed
            return code, out, err

        return kind, document[:300], refusal

    kinds = refuse_generated(HOSTILE, HOSTILE_SCENARIOS, prepare, "hostile scenarios")
    assert _listing(tmp_path) == before  # validate wrote nothing
    assert sum(kinds.values()) >= HOSTILE_SCENARIOS
    assert len(kinds) >= 40, sorted(kinds)


# --- manifests and datasets --------------------------------------------------------------------


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> dict[str, tuple[Path, bytes]]:
    """A small dataset of each format, and its manifest's bytes."""
    clips = sample_clips()[:2]
    out = {}
    for format in FORMATS:
        root = tmp_path_factory.mktemp(format)
        write_dataset(root, format, clips)
        out[format] = (root, (root / MANIFEST_NAME).read_bytes())
    return out


INT_BAD = st.one_of(LETTERS, st.just(float("nan")), st.just(1.5), st.integers(max_value=-1), st.just(2**70), st.none(),
                    st.lists(st.integers(), min_size=1), st.just({"k": 1}), st.just(True))
FLOAT_BAD = st.one_of(LETTERS, st.just(float("nan")), st.just(float("inf")), st.floats(max_value=-1e-9), st.none(),
                      st.lists(st.floats(0, 1), min_size=1), st.just(True))
STR_BAD = st.one_of(st.integers(), st.none(), st.lists(LETTERS, min_size=1), st.just({"k": "v"}), st.just(1.5))
FORGED = [
    "../../etc/hostname",
    "/etc/passwd",
    "a/../../b",
    "points/../../../x",
    MANIFEST_NAME,
    "README.md",
    ".simgen/lock",
    "a\\b",
    "a//b",
    "",
    "./x",
    "x/.",
    "a\x01b",
    "x" * 2000,
]
TYPED = {
    "files": {"path": st.one_of(STR_BAD, st.sampled_from(FORGED)), "rows": INT_BAD, "bytes": INT_BAD,
              "sha256": st.one_of(STR_BAD, LETTERS, st.just("0" * 63), st.just("G" * 64))},
    "clips": {"clip": st.one_of(STR_BAD, st.sampled_from(["../x", " ", "", "9clip", "a/b"])), "clip_index": INT_BAD,
              "frames": st.one_of(INT_BAD, st.just(0)), "points": INT_BAD, "boxes": INT_BAD,
              "split": st.one_of(STR_BAD, st.sampled_from(["test", "", "TRAIN"]))},
    "sensors": {"sensor_id": INT_BAD, "name": STR_BAD, "preset": STR_BAD, "heads": st.one_of(INT_BAD, st.just(0)),
                "shots_per_s": st.one_of(FLOAT_BAD, st.just(0.0)), "frame_rate_hz": st.one_of(FLOAT_BAD, st.just(0.0)),
                "sweeps_per_frame": st.one_of(INT_BAD, st.just(0)), "density": st.one_of(FLOAT_BAD, st.just(0.0)),
                "pose": st.one_of(STR_BAD, st.lists(st.floats(-1, 1), max_size=9).filter(lambda v: len(v) != 6),
                                  st.lists(st.one_of(LETTERS, st.just(float("nan"))), min_size=6, max_size=6))},
}
TOP = {
    "format": st.one_of(STR_BAD, LETTERS),
    "seed": INT_BAD,
    "simgen_version": st.one_of(STR_BAD, st.just("v" * 65)),
    "dependencies": st.one_of(LETTERS, st.lists(LETTERS), st.just({"numpy": 1})),
    "scenario": st.one_of(LETTERS, st.integers(), st.lists(LETTERS)),
    "sensors": st.one_of(LETTERS, st.just([]), st.integers()),
    "clips": st.one_of(LETTERS, st.just([]), st.just({})),
    "files": st.one_of(LETTERS, st.just([]), st.none()),
    "totals": st.one_of(LETTERS, st.just({"frames": 1})),
    "conventions": st.one_of(LETTERS, st.integers()),
}


@st.composite
def _manifest_case(draw) -> tuple[str, str, object]:
    """(format, kind, what to do): a manifest that must be refused as malformed."""
    format = draw(st.sampled_from(FORMATS))
    kind = draw(
        st.sampled_from(
            [
                "typed field",
                "top field",
                "missing key",
                "unknown key",
                "duplicate",
                "forged path",
                "fewer frames",
                "more frames",
                "dropped file",
                "totals",
                "not JSON",
                "deep",
                "not an object",
                "special file",
            ]
        )
    )
    if kind == "typed field":
        section = draw(st.sampled_from(sorted(TYPED)))
        key = draw(st.sampled_from(sorted(TYPED[section])))
        return format, f"{section}.{key}", ("set", section, draw(st.integers(0, 1)), key, draw(TYPED[section][key]))
    if kind == "top field":
        key = draw(st.sampled_from(sorted(TOP)))
        return format, f"top {key}", ("top", key, draw(TOP[key]))
    if kind == "missing key":
        return format, kind, ("drop key", draw(st.sampled_from(sorted(TOP))))
    if kind == "unknown key":
        return (
            format,
            kind,
            ("extra key", draw(st.sampled_from(["", "files", "clips", "sensors", "totals"])), draw(LETTERS)),
        )
    if kind == "duplicate":
        return format, kind, ("duplicate", draw(st.sampled_from(["files", "clips", "sensors"])))
    if kind == "forged path":
        return format, kind, ("forge", draw(st.sampled_from(FORGED)), draw(st.booleans()))
    if kind in ("fewer frames", "more frames"):
        return format, kind, ("frames", draw(st.integers(1, 3)) * (-1 if kind == "fewer frames" else 1))
    if kind == "dropped file":
        return format, kind, ("drop file", draw(st.integers(0, 10**6)))
    if kind == "totals":
        return (
            format,
            kind,
            ("totals", draw(st.sampled_from(["frames", "points", "boxes"])), draw(st.integers(1, 10**6))),
        )
    if kind == "not JSON":
        return (
            format,
            kind,
            ("bytes", draw(st.sampled_from(["cut", "utf8", "nan text", "empty"])), draw(st.integers(0, 10**6))),
        )
    if kind == "deep":
        return format, kind, ("deep", draw(st.integers(2_000, 200_000)))
    if kind == "not an object":
        return format, kind, ("text", draw(st.sampled_from(["[]", "\"manifest\"", "42", "null", "true"])))
    return format, kind, ("special", draw(st.sampled_from(["/dev/zero", "/dev/null", "fifo", "directory", "dangling"])))


def _corrupt(root: Path, original: bytes, action: tuple) -> None:
    """Replace the manifest of `root` as `action` says."""
    manifest = root / MANIFEST_NAME
    data = json.loads(original)
    op = action[0]
    if op == "set":
        _, section, index, key, value = action
        data[section][index % len(data[section])][key] = value
    elif op == "top":
        data[action[1]] = action[2]
    elif op == "drop key":
        del data[action[1]]
    elif op == "extra key":
        target = data if not action[1] else (data[action[1]] if action[1] == "totals" else data[action[1]][0])
        target["unknown_" + action[2]] = 1
    elif op == "duplicate":
        data[action[1]].append(data[action[1]][0])
    elif op == "forge":
        entry = {**data["files"][0], "path": action[1]}
        if action[2]:
            data["files"].append(entry)
        else:
            data["files"][0] = entry
    elif op == "frames":
        clip = data["clips"][0]
        clip["frames"] += action[1]
        data["totals"]["frames"] += action[1]
    elif op == "drop file":
        del data["files"][action[1] % len(data["files"])]
    elif op == "totals":
        data["totals"][action[1]] += action[2]
    text = json.dumps(data, indent=1, sort_keys=True)
    if op == "bytes":
        _, how, position = action
        raw = original
        if how == "cut":
            text = raw[: position % (len(raw) - 1)].decode()
        elif how == "utf8":
            at = position % len(raw)
            manifest.write_bytes(raw[:at] + b"\xff\xfe" + raw[at:])
            return
        elif how == "nan text":
            head, _, tail = raw.decode().rpartition('"seed": ')  # the top-level seed comes after the scenario's
            text = head + '"seed": NaN, "x": ' + tail
        else:
            text = ""
    elif op == "deep":
        text = "[" * action[1] + "]" * action[1]
    elif op == "text":
        text = action[1]
    elif op == "special":
        manifest.unlink()
        kind = action[1]
        if kind == "fifo":
            os.mkfifo(manifest)
        elif kind == "directory":
            manifest.mkdir()
        elif kind == "dangling":
            manifest.symlink_to(root / "no-such-file")
        else:
            manifest.symlink_to(kind)
        return
    manifest.write_text(text)


def _restore(root: Path, original: bytes) -> None:
    manifest = root / MANIFEST_NAME
    if manifest.is_dir() and not manifest.is_symlink():
        manifest.rmdir()
    elif manifest.exists() or manifest.is_symlink():
        manifest.unlink()
    manifest.write_bytes(original)


def test_generated_corrupt_manifests_are_refused_in_one_line(written):
    before = {format: _listing(root) for format, (root, _) in written.items()}
    kinds: dict[str, int] = {}
    peak = peak_bytes()

    @settings(max_examples=CORRUPT_MANIFESTS, **SETTINGS)
    @given(_manifest_case())
    def check(case):
        format, kind, action = case
        root, original = written[format]
        try:
            _corrupt(root, original, action)
            code, out, err = _run("verify", root)
            assert_one_line_refusal(code, out, err, (format, kind, action))
            with pytest.raises(UserError) as error:
                dataset = datasets.open(root)
                for _ in dataset:
                    pass
            assert "\n" not in str(error.value)
        finally:
            _restore(root, original)
        kinds[kind] = kinds.get(kind, 0) + 1

    check()
    for format, (root, _) in written.items():
        assert _listing(root) == before[format]
        datasets.open(root).verify()  # restored
    total = sum(kinds.values())
    print(
        f"{total} corrupt manifests in {len(kinds)} kinds refused; peak memory +{(peak_bytes() - peak) / 2**20:.0f} MiB"
    )
    assert total >= CORRUPT_MANIFESTS and len(kinds) >= 30, sorted(kinds)
    assert peak_bytes() - peak < MAX_GROWTH_BYTES


def test_generated_corrupt_data_files_are_caught(written):
    """A changed byte anywhere in a data file: `verify` exit 1 naming the file; the reader, one line."""
    files = {format: [f["path"] for f in json.loads(original)["files"]] for format, (_, original) in written.items()}
    seen = []

    @settings(max_examples=CORRUPT_DATA_FILES, **SETTINGS)
    @given(st.sampled_from(FORMATS), st.integers(0, 10**6), st.integers(0, 10**9), st.integers(1, 255))
    def check(format, which, position, xor):
        root, _ = written[format]
        relative = files[format][which % len(files[format])]
        path = root / relative
        original = path.read_bytes()
        changed = bytearray(original or b"\n")
        if original:
            changed[position % len(original)] ^= xor
        try:
            path.write_bytes(bytes(changed))
            code, out, err = _run("verify", root)
            assert code == 1 and f"{path}:" in out and "Traceback" not in out + err, (relative, out, err)
            with pytest.raises(UserError) as error:
                datasets.open(root).verify()
            assert relative.split("/")[-1] in str(error.value) and "\n" not in str(error.value)
        finally:
            path.write_bytes(original)
        seen.append(relative)

    check()
    assert len(seen) >= CORRUPT_DATA_FILES


# --- a handful as real processes ---------------------------------------------------------------


def _process(*arguments) -> tuple[int, str, str, int, float]:
    """`simgen ARGUMENTS` as a real process: exit code, stdout, stderr, peak resident bytes, CPU seconds."""
    return measured_process("simgen.cli", *arguments)


def test_hostile_input_in_real_processes(tmp_path, written):
    laughs = tmp_path / "laughs.yaml"
    lines = [f"l0: &l0 [{', '.join(['lol'] * 9)}]"] + [
        f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 9)}]" for i in range(1, 10)
    ]
    laughs.write_text(_dump(BASE) + "\n".join(lines) + "\n")
    deep = tmp_path / "deep.yaml"
    deep.write_text(_dump(BASE) + "motion: " + "[" * 100_000 + "]" * 100_000 + "\n")
    passwd = tmp_path / "passwd.yaml"
    passwd.write_text(
        _dump(
            {
                **BASE,
                "custom_sensors": [{"name": "c", "heads": [{"pattern": "replay", "params": {"file": "/etc/passwd"}}]}],
            }
        )
    )
    root, original = written["kitti"]
    cases = [
        ("validate", laughs),
        ("validate", deep),
        ("validate", "/dev/zero"),
        ("validate", passwd),
        ("verify", root),
    ]
    before = _listing(tmp_path)
    try:
        _corrupt(root, original, ("forge", "../../etc/hostname", True))
        for arguments in cases:
            code, out, err, peak, seconds = _process(*arguments)
            assert_one_line_refusal(code, out, err, arguments)
            assert peak < MAX_PROCESS_BYTES and seconds < 30, (arguments, peak, seconds)
    finally:
        _restore(root, original)
    assert _listing(tmp_path) == before


# --- the one YAML reader, disks that refuse, a run killed after its manifest ----------------------


@pytest.mark.parametrize(
    "document, problem",
    [
        (
            "a: " + "[" * (MAX_YAML_DEPTH + 8) + "]" * (MAX_YAML_DEPTH + 8) + "\n",
            f"nested deeper than {MAX_YAML_DEPTH} levels",
        ),
        (
            "\n".join(
                [f"l0: &l0 [{', '.join(['x'] * 10)}]"]
                + [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]" for i in range(1, 9)]
            )
            + "\n",
            f"aliases expand to more than {MAX_YAML_NODES:,} nodes",
        ),
        ("pattern: {}\npattern: {}\n", "duplicate key 'pattern'"),
    ],
)
def test_every_yaml_the_project_reads_goes_through_one_reader(tmp_path, document, problem):
    from simgen.qa.tolerances import load_tolerances
    from simgen.scenario import load_scenario
    from train.config import load_config

    path = tmp_path / "file.yaml"
    path.write_text(document)
    for load in (load_scenario, load_config, load_tolerances):
        with pytest.raises(UserError, match=problem) as error:
            load(path)
        assert "\n" not in str(error.value)
    for load in (load_scenario, load_config, load_tolerances):
        with pytest.raises(UserError, match="not a regular file"):
            load("/dev/zero")


def test_nesting_beyond_any_parser_is_refused_in_one_line_naming_the_file(tmp_path):
    """5,000 levels: refused in one line that names the file, whichever layer refuses first (our depth
    check, or a YAML library that now stops deep documents while scanning ahead)."""
    from simgen.qa.tolerances import load_tolerances
    from simgen.scenario import load_scenario
    from train.config import load_config

    path = tmp_path / "deep.yaml"
    path.write_text("a: " + "[" * 5000 + "]" * 5000 + "\n")
    for load in (load_scenario, load_config, load_tolerances):
        with pytest.raises(UserError) as error:
            load(path)
        assert str(error.value).startswith(f"{path}: ") and "\n" not in str(error.value)


def _in_a_full_file_system(arguments: list, size_kib: int, options: str = "rw") -> subprocess.CompletedProcess:
    """`simgen ARGUMENTS` with a tmpfs of `size_kib` mounted over the output's folder, in a private mount
    namespace (`unshare -m`)."""
    output = Path(arguments[arguments.index("-o") + 1])
    script = (f"mount -t tmpfs -o size={size_kib}k,{options} tmpfs {output.parent} && cd {ROOT} && "
              f"{sys.executable} -m simgen.cli {' '.join(map(str, arguments))}; code=$?; echo FILES; "
              f"find {output.parent} -type f; exit $code")
    return subprocess.run(["unshare", "-m", "sh", "-c", script], capture_output=True, text=True, timeout=600)


def test_a_full_disk_is_one_line_and_exit_2(tmp_path, written):
    """ENOSPC in `pattern` and `view` (images and exports): one line naming the output, exit 2, no temporary
    file left and no partial .npz (listed inside the namespace: after it the tmpfs is gone); EROFS too."""
    probe = subprocess.run(["unshare", "-m", "sh", "-c", f"mount -t tmpfs tmpfs {tmp_path}"], capture_output=True)
    if probe.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here (unshare -m: {probe.stderr.decode().strip()[:80]})")
    full = tmp_path / "full"
    full.mkdir()
    root, _ = written["parquet"]
    for arguments in (
        ["pattern", "mid40-rose", "--seconds", "0.2", "-o", full / "p.npz"],
        ["view", root, "-o", full / "view"],
        [
            "view",
            root,
            "--no-images",
            "--export-frame",
            "0",
            "--export-frame",
            "1",
            "--export-format",
            "ply",
            "-o",
            full / "x",
        ],
    ):
        result = _in_a_full_file_system(arguments, 16)
        assert result.returncode == 2, (arguments, result.stderr[-500:])
        last = result.stderr.strip().splitlines()[-1]
        assert last.startswith(f"simgen {arguments[0]}: error: {full}"), result.stderr
        assert "no space left" in last.lower() or "disk full" in last, result.stderr  # Open3D's own line may precede it
        assert "Traceback" not in result.stderr
        left = result.stdout.split("FILES\n", 1)[1].split()
        assert not any(".tmp" in name for name in left), left  # no temporary left behind
        assert str(full / "p.npz") not in left
    result = _in_a_full_file_system(["view", root, "-o", full / "view"], 16, "ro")  # EROFS
    assert (
        result.returncode == 2 and result.stderr == f"simgen view: error: {full / 'view'}: read-only file system\n"
    ), result.stderr


def test_resume_completes_a_run_killed_after_its_manifest(tmp_path):
    """Killed after manifest.json: --resume writes the missing card and removes the run state, no clip redone."""
    from simgen.datasets.card import dataset_card
    from simgen.datasets.manifest import read_manifest
    from simgen.pipeline.dataset_run import generate
    from simgen.pipeline.run_state import WORK_DIR
    from simgen.scenario import load_scenario

    root = tmp_path / "d"
    write_dataset(root, "parquet", sample_clips()[:2])
    card = root / "README.md"
    assert card.stat().st_mtime_ns <= (root / MANIFEST_NAME).stat().st_mtime_ns  # the card first, then the manifest
    scenario = load_scenario(ROOT / "scenarios" / "smoke.yaml")
    (root / WORK_DIR / "clips").mkdir(parents=True)
    (root / WORK_DIR / "scenario.json").write_text(json.dumps(scenario.model_dump(mode="json"), sort_keys=True))
    card.unlink()
    manifest = (root / MANIFEST_NAME).read_bytes()
    totals = generate(scenario, root, resume=True)
    assert card.read_text() == dataset_card(read_manifest(root)) and (root / MANIFEST_NAME).read_bytes() == manifest
    assert not (root / WORK_DIR).exists() and totals["clips"] == 2
    with pytest.raises(UserError, match="already complete"):
        generate(scenario, root, resume=True)


def test_replay_files_come_from_the_scenario_folder_or_the_listed_ones(tmp_path, monkeypatch):
    import numpy as np

    from simgen.scenario import PATTERN_DIRS_ENV, load_scenario

    elsewhere = tmp_path / "patterns"
    elsewhere.mkdir()
    t_s = np.arange(1, 101) * 1e-5
    np.savez(elsewhere / "p.npz", t_s=t_s, azimuth_deg=np.sin(t_s * 1e4), zenith_deg=90 + np.cos(t_s * 1e4))
    folder = tmp_path / "scenarios"
    folder.mkdir()
    (folder / "near.npz").write_bytes((elsewhere / "p.npz").read_bytes())

    def scenario(file: str) -> Path:
        path = folder / "s.yaml"
        path.write_text(
            _dump(
                {
                    **BASE,
                    "custom_sensors": [{"name": "c", "heads": [{"pattern": "replay", "params": {"file": file}}]}],
                    "sensors": [{"preset": "c"}],
                }
            )
        )
        return path

    monkeypatch.delenv(PATTERN_DIRS_ENV, raising=False)
    near = load_scenario(scenario("near.npz")).custom_sensors[0].heads[0].params["file"]
    assert near == str(folder / "near.npz")  # relative to the scenario's folder, recorded absolute
    with pytest.raises(UserError, match=f"outside the scenario's folder and \\${PATTERN_DIRS_ENV}"):
        load_scenario(scenario(str(elsewhere / "p.npz")))
    with pytest.raises(UserError, match="outside the scenario's folder"):
        load_scenario(scenario("../patterns/p.npz"))
    monkeypatch.setenv(PATTERN_DIRS_ENV, f"/nonexistent:{elsewhere}")
    assert load_scenario(scenario("../patterns/p.npz")).sensor_specs()[0].heads[0].params["file"] == str(
        elsewhere / "p.npz"
    )
