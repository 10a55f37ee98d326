"""The QA report's figures: titles wrapped to fit inside the PNG (tests/test_qa_pattern.py: no negative zero)."""

from __future__ import annotations

import matplotlib.pyplot as plt

from simgen.qa.plots import fit_titles

LONG = ("Shot pattern seen from behind the head (cones: azimuthal-equidistant; boxes: azimuth and elevation; "
        "colour: time, dark = early), and then some more words so that no figure of this width could hold it")


def test_long_titles_are_wrapped_inside_the_figure():
    fig, axes = plt.subplots(1, 2, figsize=(6, 3), layout="constrained")
    fig.suptitle(LONG)
    axes[1].set_title(LONG, fontsize=10)
    fit_titles(fig)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for text in [*fig.texts, axes[1].title]:
        extent = text.get_window_extent(renderer)
        assert 0 <= extent.x0 and extent.x1 <= fig.bbox.width, text.get_text()
        assert text.get_text().replace("\n", " ") == LONG and "\n" in text.get_text()
    plt.close(fig)

