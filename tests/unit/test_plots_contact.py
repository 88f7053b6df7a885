"""The contact protocol's errors.png: a legend that says what every bar and line is, inside the figure."""

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg

from tissuesim.experiments import contact_plots
from tissuesim.experiments.methods import protocol_methods

METHODS = [*protocol_methods(), "hybrid-near"]


def contact_results() -> dict:
    records = [{"model": model, "radius_mm": radius, "method": method, "role": "held out", "load": "pressure",
                "force_N": 1.0, "relative_rmse": 0.1 + 0.05 * k}
               for model in ("cube", "liver") for radius in (4.0, 8.0) for k, method in enumerate(METHODS)]
    references = {f"{radius:g}": {"converged": True, "load_rule_floor": 0.05} for radius in (4.0, 8.0)}
    return {"metadata": {"methods": METHODS, "models": {m: {"references": references} for m in ("cube", "liver")}},
            "records": records}


def test_the_legend_says_what_each_bar_is_and_fits_the_figure():
    figure = contact_plots.error_figure(contact_results())
    legend = figure.axes[0].get_legend()
    texts = [t.get_text() for t in legend.get_texts()]
    assert "Ours+NF: hybrid + near field" in texts and "FEM: fine-volume FEM, linear tets" in texts
    assert any(t.startswith("load rule floor (") for t in texts) and "target 0.1" in texts
    assert len(texts) == len(METHODS) + 2
    renderer = FigureCanvasAgg(figure).get_renderer()
    box, canvas = legend.get_window_extent(renderer), figure.bbox
    assert canvas.x0 <= box.x0 and box.x1 <= canvas.x1 and canvas.y0 <= box.y0 and box.y1 <= canvas.y1
    heights = [patch.get_height() for patch in figure.axes[0].patches]
    assert np.allclose(sorted(set(np.round(heights, 12))), [0.1 + 0.05 * k for k in range(len(METHODS))])
