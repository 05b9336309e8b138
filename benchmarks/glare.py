"""Glare ratings at scale: UGR and GR for N observers × 8 directions against M luminaires.

    python benchmarks/glare.py                  # 100 observers × 8 directions, the full
                                                # courtyard (configs/courtyard.toml, 3,000 lights)
    python benchmarks/glare.py --synthetic      # a synthetic site of --luminaires poles instead
    python benchmarks/glare.py --small          # a tiny run (10 × 8 against 200): a smoke test

Times, in this process: loading the scene (courtyard only), building the GlareModel (shadow
rays eye → luminaire, position indices; the background here is set to a constant instead of a
radiosity gather, which is the grids' gather and timed by benchmarks/courtyard.py), the first
evaluation (compilation included), re-evaluation of the full model at a new dimmer vector, the
same by superposition (``GlareModel.at_aims``: the goal, < 10 ms), re-evaluation at new aims, and the gradient of Σ GR_max + Σ UGR_max in dimmers, tilts, pans and
levels, with its cost relative to the value. Prints a table and the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _synthetic_scene(n_lum: int, seed: int = 0):
    """A 200 × 200 m ground with 20 columns, ``n_lum`` floodlight poles on 4 networks."""
    import dataclasses

    import tomlkit

    from lumijax.config import parse_config
    from lumijax.photometry import LuminousOpening, flood
    from lumijax.scene import build_scene

    rng = np.random.default_rng(seed)
    cols = [{"kind": "box", "min": [round(x, 2), round(y, 2), 0],
             "max": [round(x + 1, 2), round(y + 1, 2), 8], "material": "stone"}
            for x, y in rng.uniform(20, 180, (20, 2))]
    lums = [{"name": f"F{i}", "photometry": "flood", "position": [round(x, 2), round(y, 2),
                                                                 round(z, 2)],
             "network": f"n{i % 4}", "aim": {"tilt": round(t, 1), "pan": round(p, 1)}}
            for i, (x, y, z, t, p) in enumerate(zip(
                *rng.uniform(0, 200, (2, n_lum)), rng.uniform(6, 12, n_lum),
                rng.uniform(20, 60, n_lum), rng.uniform(0, 360, n_lum), strict=True))]
    cfg = parse_config(tomlkit.dumps({
        "materials": {"stone": {"reflectance": 0.3}},
        "photometry": {"flood": {"kind": "isotropic", "flux_lm": 1}},
        "geometry": [{"kind": "rectangle", "origin": [0, 0, 0], "u": [200, 0, 0],
                      "v": [0, 200, 0], "material": "stone"}, *cols],
        "luminaires": lums}))
    scene = build_scene(cfg)
    phot = dataclasses.replace(flood(20_000.0, 40.0, 25.0),
                               opening=LuminousOpening(0.5, 0.4, 0.0, "rectangle"))
    return dataclasses.replace(scene, photometries={"flood": phot})


def _observers(scene, n: int, seed: int = 1):
    from lumijax.glare import Observer

    rng = np.random.default_rng(seed)
    v = scene.triangles.vertices.reshape(-1, 3)
    lo, hi = v.min(0), v.max(0)
    centre, half = 0.5 * (lo + hi), 0.3 * (hi - lo)
    out = []
    for i in range(n):
        xy = centre[:2] + rng.uniform(-1, 1, 2) * half[:2]
        a = rng.uniform(0, 2 * np.pi)
        out.append(Observer.looking(f"o{i}", [xy[0], xy[1], lo[2] + 1.6],
                                    [np.cos(a), np.sin(a), -0.035],
                                    fan_deg=tuple(range(0, 360, 45))))
    return out


def _time(f, repeat: int = 20) -> float:
    """Median seconds of ``f()`` (blocking on its result)."""
    import jax

    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        jax.block_until_ready(f())
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--observers", type=int, default=100)
    p.add_argument("--luminaires", type=int, default=3000, help="synthetic site only")
    p.add_argument("--synthetic", action="store_true", help="a synthetic site, not the courtyard")
    p.add_argument("--small", action="store_true", help="10 observers against 200 luminaires")
    args = p.parse_args(argv)
    if args.small:
        args.observers, args.luminaires, args.synthetic = 10, 200, True

    import equinox as eqx
    import jax
    import jax.numpy as jnp

    from lumijax.design import Design
    from lumijax.glare import build_glare_model

    rows = []
    t = time.perf_counter()
    config = ROOT / "configs" / "courtyard.toml"
    if args.synthetic or not config.is_file():
        scene = _synthetic_scene(args.luminaires)
        where = f"synthetic site, {len(scene.luminaires)} luminaires"
    else:
        from lumijax import load_study

        scene = load_study(config).scene
        where = f"{config.name}, {len(scene.luminaires)} luminaires"
    rows.append(("load the scene", time.perf_counter() - t))
    observers = _observers(scene, args.observers)
    t = time.perf_counter()
    model = build_glare_model(scene, observers)
    rows.append(("build the model (rays, position indices)", time.perf_counter() - t))
    k, v = len(scene.networks), model.n_views
    # a constant background instead of the radiosity gather (see the module docstring)
    model = eqx.tree_at(lambda m: (m.background, m.environment), model,
                        (jnp.asarray(np.full((v, k), 2.0)), jnp.asarray(np.full((v, k), 1.0))))
    design = Design.of(scene)
    t = time.perf_counter()
    jax.block_until_ready(model(design))
    rows.append(("first evaluation (compiles)", time.perf_counter() - t))
    rng = np.random.default_rng(2)
    dimmed = design.replace(dimmers=rng.uniform(0.2, 1.0, k))
    rows.append(("re-evaluate the full model at new dimmers", _time(lambda: model(dimmed))))
    t = time.perf_counter()
    fast = model.at_aims(design)
    jax.block_until_ready(fast(dimmed.dimmers))
    rows.append(("sum per network at the aims (DimmerGlare)", time.perf_counter() - t))
    value_s = _time(lambda: fast(dimmed.dimmers), repeat=200)
    rows.append(("re-evaluate at new dimmers (superposition)", value_s))
    exact = model(dimmed)
    gap = float(jnp.max(jnp.abs(fast(dimmed.dimmers).gr - exact.gr)))
    turned = design.replace(tilt_deg=np.asarray(design.tilt_deg) + 3.0)
    rows.append(("re-evaluate at new aims", _time(lambda: model(turned))))

    def objective(x):
        d = Design(x[:k], design.tilt_deg + x[k], design.pan_deg + x[k + 1],
                   design.spin_deg, design.level * x[k + 2], networks=design.networks,
                   luminaires=design.luminaires)
        r = model.ratings(d)
        return jnp.sum(model.worst(r.gr)) + jnp.sum(model.worst(r.ugr))

    x0 = jnp.concatenate([jnp.asarray(dimmed.dimmers), jnp.zeros(2), jnp.ones(1)])
    grad = jax.jit(jax.grad(objective))
    value = jax.jit(objective)
    t = time.perf_counter()
    jax.block_until_ready(grad(x0))
    rows.append(("first gradient (compiles)", time.perf_counter() - t))
    value_j = _time(lambda: value(x0))
    grad_s = _time(lambda: grad(x0))
    rows.append(("objective value (jit)", value_j))
    rows.append(("gradient in dimmers, aims, levels (jit)", grad_s))

    print(f"glare: {len(observers)} observers × 8 directions = {v} views, {where}, "
          f"{k} networks")
    print(f"{'step':<46} {'seconds':>10}")
    for name, s in rows:
        print(f"{name:<46} {s:>10.5f}")
    print(f"{'gradient / value':<46} {grad_s / value_j:>10.2f}")
    print(f"re-evaluation goal < 10 ms: {'met' if value_s < 0.01 else 'not met'} "
          f"({value_s * 1e3:.3f} ms, {value_s / 0.01:.3f} of the goal; superposed GR within "
          f"{gap:.1e} of the full model's)")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"JAX {jax.__version__} on {jax.default_backend()}")


if __name__ == "__main__":
    main()
