"""`simgen qa --pattern`: verdicts against Livox's official file, the report, and a browser that shows it."""

from __future__ import annotations

import hashlib
import re
import subprocess

import cv2
import pytest
import yaml

from scan_patterns import HeadSpec
from simgen.cli import main
from simgen.qa.pattern import head_qa
from simgen.qa.tolerances import DEFAULT_PATH, load_tolerances
from tests.support import ROOT, chromium
from tests.support.processes import run_simgen


@pytest.fixture(scope="module")
def risley(tmp_path_factory):
    out = tmp_path_factory.mktemp("qa") / "risley"
    return out, run_simgen("qa", "--pattern", "mid40-risley", "-o", out)


def test_the_fitted_risley_pattern_passes_against_the_official_file(risley):
    out, result = risley
    assert result.returncode == 0, result.stdout + result.stderr
    assert "PASS: 6 passed, 0 failed, 0 not applicable" in result.stdout
    assert not re.search(r"^FAIL", result.stdout, re.M)
    markdown = (out / "report.md").read_text()
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", markdown)
    assert len(images) == 4 and all((out / image).is_file() for image in images)
    assert "| pass | mid40-risley head 0 | coverage, 0.2 deg cells |" in markdown
    assert not re.search(r"-0\.0+\b(?!\d)", markdown)  # no negative zero: a difference that rounds to 0 reads +0.00


def test_the_papers_rose_fails_where_it_differs_from_the_sensor(tmp_path):
    result = run_simgen("qa", "--pattern", "mid40-rose", "-o", tmp_path)
    assert result.returncode == 1, result.stdout + result.stderr
    rows = [re.split(r"\s{2,}", line) for line in result.stdout.splitlines()[1:-1]]
    verdicts = {f"{row[0]} {row[2]}" for row in rows}
    assert "FAIL coverage, 0.1 deg cells" in verdicts and "FAIL radial density" in verdicts
    assert "pass points per frame on a 0.5 x 1.8 m target" in verdicts and "pass shot rate" in verdicts


def test_chromium_shows_the_report_alone_with_every_image_loaded(risley, tmp_path):
    out, _ = risley
    alone = tmp_path / "attached"  # index.html on its own, as attached to a ticket
    alone.mkdir()
    (alone / "index.html").write_bytes((out / "index.html").read_bytes())
    sources = re.findall(r'<img[^>]* src="([^"]*)"', (alone / "index.html").read_text())
    expected = len(list((out / "plots").glob("*.png")))
    assert len(sources) == expected and all(src.startswith("data:image/png;base64,") for src in sources)
    url = (alone / "index.html").as_uri()

    dom = chromium.run("--virtual-time-budget=10000", "--dump-dom", url).stdout
    assert f'data-images-loaded="{expected}/{expected}"' in dom, dom[:500]
    shot = tmp_path / "report.png"
    chromium.run(f"--screenshot={shot}", "--window-size=1400,3000", url)
    image = cv2.imread(str(shot))
    assert image.shape == (3000, 1400, 3) and image.std() > 20  # a page, not a blank one


def test_tolerances_are_validated_and_an_edited_copy_is_used(tmp_path, capsys):
    edited = yaml.safe_load(DEFAULT_PATH.read_text())
    edited["pattern"]["coverage_points"] = 15
    path = tmp_path / "mine.yaml"
    path.write_text(yaml.safe_dump(edited))
    assert load_tolerances(path).pattern.coverage_points == 15.0
    for change, message in (
        (lambda t: t["pattern"].update(coverage_pts=1), "unknown key 'pattern.coverage_pts' (known: coverage_points, "),
        (lambda t: t["labels"].pop("max_speed_mps"), "missing key 'labels.max_speed_mps'"),
        (lambda t: t["dataset"].update(dropout_points=-1), "'dataset.dropout_points' must be a number >= 0 (got -1)"),
        (lambda t: t.update(extra={}), "unknown key 'extra' (known: pattern, dataset, labels)"),
    ):
        bad = yaml.safe_load(DEFAULT_PATH.read_text())
        change(bad)
        path.write_text(yaml.safe_dump(bad))
        assert main(["qa", "--pattern", "mid40-risley", "-o", str(tmp_path / "out"), "--tolerances", str(path)]) == 2
        stderr = capsys.readouterr().err
        assert stderr.count("\n") == 1 and message in stderr, stderr
    assert not (tmp_path / "out").exists()


def test_the_report_names_the_tolerances_without_their_folder(risley, tmp_path):
    out, _ = risley
    shipped = "tolerances from simgen/qa/tolerances.yaml (shipped)."
    assert shipped in (out / "report.md").read_text() and shipped in (out / "index.html").read_text()
    grep = subprocess.run(["grep", "-rlF", str(ROOT), str(out)], capture_output=True, text=True)  # $PWD of run_simgen
    assert grep.returncode == 1 and grep.stdout == ""
    mine = tmp_path / "mine.yaml"
    mine.write_bytes(DEFAULT_PATH.read_bytes())
    source = load_tolerances(mine).source
    assert source == f"mine.yaml (sha256 {hashlib.sha256(mine.read_bytes()).hexdigest()[:12]})"


def test_bad_input_is_one_line(tmp_path):
    result = run_simgen("qa", "--pattern", "mid41", "-o", tmp_path / "out")
    assert result.returncode == 2 and result.stderr.startswith("simgen qa: error: unknown sensor 'mid41'")
    result = run_simgen("qa", tmp_path / "nothing", "-o", tmp_path / "out")
    assert (
        result.returncode == 2
        and result.stderr == f"simgen qa: error: {tmp_path / 'nothing'}: no such dataset directory\n"
    )


def test_a_head_without_an_official_file_is_reported_not_failed():
    head = HeadSpec("rose", fov_deg=50.0)
    qa = head_qa("wide head 0", head, load_tolerances().pattern)
    assert [(c.name, c.verdict, c.measured) for c in qa.checks] == [
        ("official pattern", "n/a", "Livox ships no file for a 50 deg head")]
