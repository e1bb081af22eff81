"""The several-levels page on the report's templates: same page frame, guide,
escaping and figure style as the experiment report."""

from __future__ import annotations

import re

import pytest
from matplotlib.text import Text

from motorid.report import figures


@pytest.fixture(scope="module")
def levels_result():
    from motorid.identification.hammerstein import identify_levels
    from motorid.trainer.multilevel import multilevel_experiment

    exp = multilevel_experiment("deadzone-rails", levels=(2.0, 4.0, 6.0, 10.0), repeats=1, seed=7)
    return identify_levels([c.capture for c in exp.captures])


def test_levels_page_uses_the_report_frame(levels_result, monkeypatch):
    from motorid.report.levels import build_levels_report

    kept = []
    real_png = figures.png
    monkeypatch.setattr(figures, "png", lambda fig: kept.append(fig) or real_png(fig))
    html = build_levels_report(levels_result, title="levels <&> test")
    for sid in ("static", "levels", "model"):
        assert f'<section id="{sid}">' in html, sid
    assert "<title>levels &lt;&amp;&gt; test</title>" in html
    assert 'id="guide"' in html and "@page" in html
    assert "not available" not in html
    st = levels_result.static
    assert f"{st.dead_zone_v:.4g} V" in html and f"{st.gain:.4g} V/V" in html
    assert len(re.findall(r'<img alt="[^"]+" src="data:image/png;base64,', html)) == 2
    assert len(kept) == 2
    for fig in kept:
        assert fig.get_figwidth() == pytest.approx(figures.FULL_WIDTH_IN)
        fig.canvas.draw()
        small = [t.get_text() for t in fig.findobj(Text)
                 if t.get_visible() and t.get_text().strip() and t.get_fontsize() < figures.FONT_PT]
        assert not small, small
