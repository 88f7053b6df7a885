"""The self-weight figure of docs/gravity-and-supports.md, and the numbers beside it.

Left: a laterally free column (ν = 0, 20 × 20 × 100 mm, base fixed) under its weight, u_z(z) against the analytic
parabola −ρg(Hz − z²/2)/E, for every method on TetGen's meshes of its surface (4 × 4 × 20 faces) and the linear FEM
on Kuhn-split hex meshes (4 to 24 layers). Middle: the top's sag against ρgH²/(2E) over E, ρ and g, for each method
(a line of slope 1 is the analytic answer). Right: each method's relative RMS difference from the fine FEM under
gravity on the cube, sphere and liver, with the fine FEM's own change on a finer model.

    python benchmarks/figure_self_weight.py [--output docs/figures/self_weight.png]
"""

from __future__ import annotations

import argparse

import numpy as np

from tissuesim import HybridMesh, SurfaceMesh, make_solver, models
from tissuesim.experiments.methods import colour as method_colour
from tissuesim.solvers import available_solvers
from tissuesim.fem.assembly import body_force
from tissuesim.fem.linear import LinearFEM
from tissuesim.mesh.tetmesh import structured_box

E, RHO, GRAVITY, H, W = 5500.0, 1000.0, 9.81, 0.1, 0.02
METHODS = ("fem", "hybrid", "embedded", "pbd", "mass-spring")
#: (E [Pa], ρ [kg/m³], g [m/s²]) of the scaling panel.
SCALINGS = ((5500.0, 1000.0, 9.81), (11000.0, 1000.0, 9.81), (5500.0, 2000.0, 9.81), (2750.0, 1000.0, 9.81),
            (5500.0, 1000.0, 19.62), (22000.0, 1050.0, 9.81))


def column_mesh(divisions):
    return structured_box([W, W, H], divisions, origin=(-W / 2, -W / 2, 0.0))


def column_surface(divisions) -> SurfaceMesh:
    mesh = column_mesh(divisions)
    triangles = mesh.boundary_triangles
    used = np.unique(triangles)
    index = np.full(mesh.node_count, -1)
    index[used] = np.arange(used.size)
    return SurfaceMesh(mesh.points[used], index[triangles].astype(np.int32))


def analytic_uz(z, *, youngs_modulus=E, density=RHO, gravity=GRAVITY):
    return -density * gravity * (H * z - 0.5 * z * z) / youngs_modulus


def structured_profiles() -> list[tuple[int, np.ndarray, np.ndarray]]:
    """``(layers, z, u_z)`` along the column's axis of LinearFEM on Kuhn-split hex columns."""
    profiles = []
    for n in (1, 2, 6):
        mesh = column_mesh((n, n, 4 * n))
        fem = LinearFEM(mesh, youngs_modulus=E, poisson_ratio=0.0, fixed=np.flatnonzero(mesh.points[:, 2] < 1e-12))
        u = fem.solve(body_force(mesh, RHO, (0.0, 0.0, -GRAVITY)))
        axis = np.flatnonzero(np.linalg.norm(mesh.points[:, :2], axis=1) < 1e-12) if n % 2 == 0 else \
            np.flatnonzero(np.abs(mesh.points[:, 0] + W / 2) + np.abs(mesh.points[:, 1] + W / 2) < 1e-12)
        order = axis[np.argsort(mesh.points[axis, 2])]
        profiles.append((4 * n, mesh.points[order, 2], u[order, 2]))
    return profiles


def column_runs(hybrid):
    """Per method: ``(z (n,), u_z (n,))`` of every M_S vertex under the paper's material, and the top's sag [m] per
    :data:`SCALINGS` entry."""
    v = hybrid.surface.vertices
    base, top = np.flatnonzero(v[:, 2] < 1e-12), v[:, 2] > H - 1e-12
    runs = {}
    for method in METHODS:
        sags = []
        for youngs_modulus, density, gravity in SCALINGS:
            solver = make_solver(method, hybrid, poisson_ratio=0.0, fixed=base, youngs_modulus=youngs_modulus,
                                 density=density, gravity=(0.0, 0.0, -gravity))
            u = solver.solve_static(max_steps=40000) - v
            sags.append(-u[top, 2].mean())
            if (youngs_modulus, density, gravity) == SCALINGS[0]:
                profile = (v[:, 2], u[:, 2])
        runs[method] = (profile, np.array(sags))
    return runs


def model_differences() -> dict[str, dict[str, float]]:
    """Relative RMS difference of each method from the fine FEM under gravity, per model; ``"fem (finer)"``: the
    fine FEM on a model of twice the vertices against the default one, at the default model's vertices (nearest)."""
    table = {}
    for name in ("cube", "sphere", "liver"):
        hybrid = HybridMesh.build(models.model(name))
        v = hybrid.surface.vertices
        reference = make_solver("fem", hybrid, gravity=(0.0, 0.0, -GRAVITY)).solve_static() - v
        scale = np.sqrt(np.mean(np.sum(reference**2, axis=1)))
        row = {}
        for method in METHODS[1:]:
            u = make_solver(method, hybrid, gravity=(0.0, 0.0, -GRAVITY)).solve_static(max_steps=40000) - v
            row[method] = float(np.sqrt(np.mean(np.sum((u - reference) ** 2, axis=1))) / scale)
        finer = HybridMesh.build(models.model(name, 2 * hybrid.surface.vertex_count))
        w = finer.surface.vertices
        fine_u = make_solver("fem", finer, gravity=(0.0, 0.0, -GRAVITY)).solve_static() - w
        nearest = np.argmin(np.linalg.norm(v[:, None, :] - w[None, :, :], axis=2), axis=1)
        row["fem (finer)"] = float(np.sqrt(np.mean(np.sum((fine_u[nearest] - reference) ** 2, axis=1))) / scale)
        table[name] = row
    return table


def draw(profiles, runs, table, output: str) -> None:
    from matplotlib.figure import Figure

    figure = Figure(figsize=(15.0, 4.8), dpi=110)
    left, middle, right = figure.subplots(1, 3)
    z = np.linspace(0.0, H, 101)
    left.plot(1e3 * analytic_uz(z), 1e3 * z, color="black", linewidth=2.5, label="analytic −ρg(Hz − z²/2)/E")
    for (layers, zs, uz), colour in zip(profiles, ("tab:purple", "tab:brown", "tab:cyan")):
        left.plot(1e3 * uz, 1e3 * zs, linestyle=":", marker=".", linewidth=1.0, color=colour,
                  label=f"linear FEM, Kuhn hexes, {layers} layers (axis)")
    for method, ((zs, uz), _) in runs.items():
        left.scatter(1e3 * uz, 1e3 * zs, s=6, color=method_colour(method), alpha=0.6, label=f"{method} (M_S vertices)")
    left.set_xlabel("u_z [mm]")
    left.set_ylabel("z [mm]")
    left.set_title("column under its weight (ν = 0, base fixed)")
    left.legend(fontsize=7, loc="lower left")
    expected = np.array([d * g * H * H / (2 * e) for e, d, g in SCALINGS])
    middle.plot([0, 1e3 * expected.max() * 1.1], [0, 1e3 * expected.max() * 1.1], color="black", linewidth=1.0,
                label="analytic (slope 1)")
    markers = {"fem": ("o", 11), "hybrid": ("x", 8), "embedded": ("+", 10), "pbd": ("o", 5), "mass-spring": ("s", 5)}
    for method, (_, sags) in runs.items():
        marker, size = markers[method]
        middle.plot(1e3 * expected, 1e3 * sags, marker, color=method_colour(method), label=method, markersize=size,
                    markerfacecolor="none" if method == "fem" else None, linestyle="none")
    middle.set_xlabel("ρgH²/(2E) [mm]")
    middle.set_ylabel("sag of the top [mm]")
    middle.set_title("sag against ρgH²/(2E) over E, ρ and g")
    middle.legend(fontsize=8)
    names = list(table)
    columns = list(next(iter(table.values())))
    width = 0.8 / len(columns)
    for k, column in enumerate(columns):
        right.bar(np.arange(len(names)) - 0.4 + (k + 0.5) * width, [table[n][column] for n in names], width,
                  color=method_colour(column) if column in available_solvers() else "lightgrey", label=column,
                  hatch="//" if column == "fem (finer)" else None)
    right.set_xticks(np.arange(len(names)), names)
    right.set_ylabel("relative RMS difference from the fine FEM")
    right.set_title("models under gravity (bottom fixed, ν = 0.3)")
    right.set_ylim(0.0, 1.25)
    right.legend(fontsize=8, ncol=3, loc="upper left")
    figure.tight_layout()
    figure.savefig(output)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default="docs/figures/self_weight.png")
    args = parser.parse_args(argv)
    profiles = structured_profiles()
    hybrid = HybridMesh.build(column_surface((4, 4, 20)))
    runs = column_runs(hybrid)
    expected = np.array([d * g * H * H / (2 * e) for e, d, g in SCALINGS])
    print(f"column: {hybrid.surface.vertex_count} M_S vertices; top sag / ρgH²/(2E) per (E, ρ, g) of {SCALINGS}")
    for method, (_, sags) in runs.items():
        print(f"  {method:12s}", " ".join(f"{r:.4f}" for r in sags / expected))
    table = model_differences()
    print("relative RMS difference from the fine FEM under gravity:")
    for name, row in table.items():
        print(f"  {name:7s}", "  ".join(f"{k} {v:.3f}" for k, v in row.items()))
    draw(profiles, runs, table, args.output)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
