"""The constraints evaluated together (``_constraints.constraint_values``): every batched grid
criterion against its own ``value`` and against numpy's closed forms, the graph independent of
the number of constraints, and a dimmer-only design compiling two programs."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from lumijax.optimise._constraints import (
    DesignLight,
    GridAverage,
    GridLuminance,
    GridMaximum,
    GridMinimum,
    GridUniformity,
    MapMisfit,
    PatchLuminance,
    constraint_margins,
    constraint_values,
)

jax.config.update("jax_enable_x64", True)

# three grids of 20, 1 and 29 points and a dark one of 5 (U0 of a dark grid is 0)
SLICES = [(0, 20), (20, 21), (21, 50), (50, 55)]
RNG = np.random.default_rng(7)
E = np.concatenate([RNG.uniform(5.0, 200.0, 50), np.zeros(5)])
B = RNG.uniform(0.0, 300.0, 12)


def _kw(cls, start, stop, bound, sense, **extra):
    return cls(label=f"{cls.__name__}[{start}:{stop}]", key="k", unit="", sense=sense,
               bound=jnp.asarray(bound), ref=abs(bound), start=start, stop=stop, **extra)


def _mixed():
    out = []
    for start, stop in SLICES:
        out += [_kw(GridAverage, start, stop, 50.0, 1), _kw(GridMinimum, start, stop, 10.0, 1),
                _kw(GridMaximum, start, stop, 150.0, -1), _kw(GridUniformity, start, stop, 0.3, 1),
                _kw(GridLuminance, start, stop, 20.0, -1, rho=0.4)]
    # evaluated alone, between the batched ones: the order must come back
    out.insert(3, _kw(MapMisfit, 0, 20, 0.05, -1, target=jnp.asarray(E[:20] * 1.1)))
    out.insert(9, PatchLuminance(label="patches", key="k", unit="", sense=-1,
                                 bound=jnp.asarray(80.0), ref=80.0))
    return tuple(out)


def _light(e=E):
    return DesignLight(jnp.asarray(e), jnp.asarray(B), jnp.ones(2), jnp.ones(2))


@pytest.mark.parametrize("smooth", [1e-2, 1e-3, None])
def test_batched_values_equal_each_constraints_own(smooth):
    cs = _mixed()

    @jax.jit  # op by op each primitive would compile its own kernel
    def both(e):
        light = _light(e)
        return (constraint_values(cs, light, smooth), constraint_margins(cs, light, smooth),
                jnp.stack([c.value(light, smooth) for c in cs]),
                jnp.stack([c.margin(light, smooth) for c in cs]))

    got, margins, want, want_margins = (np.asarray(a) for a in both(jnp.asarray(E)))
    np.testing.assert_allclose(got, want, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(margins, want_margins, rtol=1e-13, atol=1e-13)


def test_batched_gradients_equal_each_constraints_own():
    cs = _mixed()

    def batched(e):
        return constraint_values(cs, _light(e), 1e-3)

    def alone(e):
        return jnp.stack([c.value(_light(e), 1e-3) for c in cs])

    e = jnp.asarray(E)  # compiled: op by op each primitive would compile its own kernel
    np.testing.assert_allclose(np.asarray(jax.jit(jax.jacrev(batched))(e)),
                               np.asarray(jax.jit(jax.jacrev(alone))(e)), rtol=1e-12,
                               atol=1e-12)


def test_exact_batched_values_are_the_closed_forms():
    """Eavg, Emin, Emax, U0 = Emin / Eavg (0 on a dark grid) and ρ Emax / π, by numpy."""
    cs = [c for c in _mixed() if not isinstance(c, MapMisfit | PatchLuminance)]
    got = np.asarray(constraint_values(cs, _light(), None)).reshape(len(SLICES), 5)
    for row, (start, stop) in zip(got, SLICES, strict=True):
        e = E[start:stop]
        u0 = e.min() / e.mean() if e.mean() > 0 else 0.0
        np.testing.assert_allclose(row, [e.mean(), e.min(), e.max(), u0, 0.4 * e.max() / np.pi],
                                   rtol=1e-14, atol=1e-14)


def test_soft_batched_values_keep_the_stated_bounds():
    """min − ε·ref ≤ smooth Emin ≤ min and max ≤ smooth Emax ≤ max + ε·ref (refs 10, 150)."""
    eps = 1e-2
    for start, stop in SLICES[:3]:
        e = E[start:stop]
        lo, hi = _kw(GridMinimum, start, stop, 10.0, 1), _kw(GridMaximum, start, stop, 150.0, -1)
        smin, smax = np.asarray(jax.jit(lambda e, c=(lo, hi): constraint_values(
            c, _light(e), eps))(jnp.asarray(E)))
        assert e.min() - eps * 10.0 - 1e-12 <= smin <= e.min() + 1e-12
        assert e.max() - 1e-12 <= smax <= e.max() + eps * 150.0 + 1e-12


def test_graph_does_not_grow_with_the_number_of_constraints():
    """Ten grid constraints (five kinds on two grids) or twenty (on four): one batch, the same
    number of operations to compile (traced alone each constraint added its own ~20)."""
    many = tuple(c for c in _mixed() if not isinstance(c, MapMisfit | PatchLuminance))
    few = many[:10]

    def size(cs):
        jaxpr = jax.make_jaxpr(lambda e: constraint_values(cs, _light(e), 1e-3))(jnp.asarray(E))
        return len(jaxpr.eqns)

    assert len(many) == 2 * len(few) and len({type(c) for c in few}) == 5
    assert size(many) == size(few)


def test_dimmer_design_compiles_two_programs(facade_results):
    """A least-power design over the dimmers compiles one program for the solve (f, ∇f, the
    margins, their Jacobian, the exact values) and one for the check of the lit design — 48 in
    the demo's before the constraints were batched and the solve's programs fused — and the same
    design asked again compiles nothing (no re-tracing: the programs' static parts hash
    stably). New bounds compile the two again: each constraint's reference level is static."""
    import jax.monitoring as mon

    from lumijax.optimise import optimise

    study, results = facade_results
    s = results.grids["wall"].stats
    compiled = []

    def listen(event, duration, **_):
        if event == "/jax/core/compile/backend_compile_duration":
            compiled.append(duration)

    def design(scale):
        return optimise(study, results, objective="power", variables=["dimmers"], constraints=[
            {"criterion": "u0", "grid": "wall", "min": round(0.7 * scale * s["u0"], 5)},
            {"criterion": "min", "grid": "wall", "min": round(0.5 * scale * s["min"], 4)},
            {"criterion": "max", "grid": "wall", "max": round(1.2 * s["max"], 1)}])

    mon.register_event_duration_secs_listener(listen)
    try:
        first = design(1.0)
        n_first = len(compiled)
        second = design(1.0)
    finally:
        mon.unregister_event_duration_listener(listen)
    assert first.constrained["verdict"] == second.constrained["verdict"] == "met"
    assert second.constrained["objective_end"] == first.constrained["objective_end"]
    assert n_first <= 3  # the two programs (and at most one host-to-device copy kernel)
    assert len(compiled) == n_first
