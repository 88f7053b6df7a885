"""The radar plots (Figs 12–15): nodes 2–10 on a scale relative to the reference, the load node apart, titles and
ring labels that nothing covers or cuts off."""

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from tissuesim.experiments import plots
from tissuesim.experiments.methods import short_label

# method -> scale of the reference's displacements: every method's d is this multiple of the reference's
FACTORS = {"hybrid": 0.9, "pbd": 0.5, "mass-spring": 1.2, "embedded": 0.8, "fem": 1.0}
# The reference's d per newton [mm/N] of the 10 sample nodes: a spike at the load node, the rest near 1.
REFERENCE = np.array([9.0, 1.6, 1.2, 1.0, 0.9, 1.1, 0.8, 0.7, 1.0, 0.6])


def results(forces=(1.0, 10.0), factors=FACTORS, reference=REFERENCE) -> dict:
    records = [{"model": "cube", "load": load, "force_N": force, "method": method,
                "displacements_mm": list(reference * force * factor)}
               for load in ("tension", "pressure") for force in forces for method, factor in factors.items()]
    return {"metadata": {"models": {"cube": {}}}, "records": records}


def radars(figure) -> list:
    return [ax for ax in figure.get_axes() if any(t.get_gid() == "ring-label" for t in ax.texts)]


def bars(figure) -> list:
    return [ax for ax in figure.get_axes() if ax.patches]


def lines_of(ax) -> dict:
    return {line.get_label(): line for line in ax.get_lines() if not line.get_label().startswith("_")}


def test_each_case_has_a_radar_of_nodes_2_to_10_relative_to_the_reference():
    figure = plots.radar_figure(results(forces=(1.0, 2.0, 5.0)), "cube")
    assert len(radars(figure)) == 6 and len(bars(figure)) == 6
    rms = np.sqrt(np.mean(REFERENCE[1:] ** 2))
    rim = plots._rim([(1.0, {"fem": REFERENCE / rms})])
    for ax in radars(figure):
        lines = lines_of(ax)
        assert sorted(lines) == sorted(short_label(m) for m in FACTORS)
        for method, factor in FACTORS.items():
            x, y = lines[short_label(method)].get_xdata(), lines[short_label(method)].get_ydata()
            radii = np.hypot(x, y)
            # a closed polygon over the 9 nodes 2-10 (node 2 straight up), radius d / (reference RMS) / rim
            assert len(radii) == 10 and radii[-1] == pytest.approx(radii[0], rel=1e-12)
            assert x[0] == pytest.approx(0.0, abs=1e-12) and y[0] > 0
            assert radii[:9] == pytest.approx(factor * REFERENCE[1:] / rms / rim, rel=1e-12)


def test_relative_samples_do_not_change_with_the_force_or_the_unit():
    found = {m: f * REFERENCE for m, f in FACTORS.items()}
    rms, relative = plots.relative_samples(found)
    assert rms == pytest.approx(np.sqrt(np.mean(REFERENCE[1:] ** 2)), rel=1e-12)
    assert np.sqrt(np.mean(relative["fem"][1:] ** 2)) == pytest.approx(1.0, rel=1e-12)
    rms_big, relative_big = plots.relative_samples({m: 1e3 * d for m, d in found.items()})
    assert rms_big == pytest.approx(1e3 * rms, rel=1e-12)
    for method in FACTORS:
        assert relative_big[method] == pytest.approx(relative[method], rel=1e-12)


def test_relative_samples_need_a_reference_that_moved():
    assert plots.relative_samples({"hybrid": REFERENCE}) is None
    assert plots.relative_samples({"fem": np.array([3.0, 0.0, 0.0]), "hybrid": REFERENCE[:3]}) is None


def test_the_load_node_is_drawn_apart_on_the_same_scale():
    figure = plots.radar_figure(results(forces=(1.0,)), "cube")
    rms = np.sqrt(np.mean(REFERENCE[1:] ** 2))
    for ax in bars(figure):
        widths = [patch.get_width() for patch in ax.patches]
        assert widths == pytest.approx([FACTORS[m] * REFERENCE[0] / rms for m in FACTORS], rel=1e-12)
        assert ax.get_xlim()[1] > max(widths)  # no bar runs off its axis


def test_the_rim_follows_the_reference_and_a_method_far_off_is_clipped_and_named():
    factors = {**FACTORS, "pbd": 50.0}
    figure = plots.radar_figure(results(forces=(1.0,), factors=factors), "cube")
    rms = np.sqrt(np.mean(REFERENCE[1:] ** 2))
    largest = REFERENCE[1:].max() / rms  # 1.59: the rim is 1.25 x that, up to the next 0.5
    rim = np.ceil(1.25 * largest / 0.5) * 0.5
    for ax in radars(figure):
        lines = lines_of(ax)
        assert np.hypot(lines["PBD"].get_xdata(), lines["PBD"].get_ydata()) == pytest.approx(np.ones(10))
        fem = np.hypot(lines["FEM"].get_xdata(), lines["FEM"].get_ydata())
        assert fem.max() == pytest.approx(largest / rim, rel=1e-12)
        assert any(t.get_text() == "beyond the rim: PBD" for t in ax.texts)
        assert not any("MSM" in t.get_text() for t in ax.texts)  # 1.2 x the reference: inside the rim


def test_a_case_without_reference_says_so():
    data = results(forces=(1.0,))
    data["records"] = [r for r in data["records"] if not (r["method"] == "fem" and r["load"] == "tension")]
    figure = plots.radar_figure(data, "cube")
    titles = [ax.get_title() for ax in figure.get_axes()]
    assert sum("no reference" in t for t in titles) == 1


@pytest.mark.parametrize("forces", [(1.0,), (1.0, 10.0), (0.5, 1.0, 2.0, 5.0, 10.0, 20.0)])
def test_titles_fit_the_figure_and_cover_no_panel(forces):
    figure = plots.radar_figure(results(forces=forces), "cube")
    renderer = FigureCanvasAgg(figure).get_renderer()
    canvas = figure.bbox
    texts = list(figure.texts) + [ax.title for ax in figure.get_axes()]
    for text in texts:
        box = text.get_window_extent(renderer)
        assert canvas.x0 <= box.x0 and box.x1 <= canvas.x1 and canvas.y0 <= box.y0 and box.y1 <= canvas.y1, \
            text.get_text()
    for text in figure.texts:
        box = text.get_window_extent(renderer)
        for ax in figure.get_axes():
            assert not box.overlaps(ax.get_tightbbox(renderer)), text.get_text()
    legend = figure.legends[0].get_window_extent(renderer)
    assert canvas.y0 <= legend.y0 and not any(legend.overlaps(ax.get_tightbbox(renderer)) for ax in figure.get_axes())


def test_ring_labels_are_clear_of_every_line():
    factors = {**FACTORS, "pbd": 50.0, "embedded": 1.3}  # a line at the rim and one beyond the reference
    figure = plots.radar_figure(results(forces=(1.0, 10.0), factors=factors), "cube")
    renderer = FigureCanvasAgg(figure).get_renderer()
    for ax in radars(figure):
        labels = [t.get_window_extent(renderer) for t in ax.texts if t.get_gid() == "ring-label"]
        assert len(labels) >= 3
        for line in lines_of(ax).values():
            xy = np.column_stack([line.get_xdata(), line.get_ydata()])
            t = np.linspace(0.0, 1.0, 40)[:, None, None]
            points = (xy[:-1] + t * (xy[1:] - xy[:-1])).reshape(-1, 2)  # 40 points along every edge
            pixels = ax.transData.transform(points)
            for box in labels:
                inside = ((box.x0 <= pixels[:, 0]) & (pixels[:, 0] <= box.x1) & (box.y0 <= pixels[:, 1])
                          & (pixels[:, 1] <= box.y1))
                assert not inside.any(), line.get_label()
