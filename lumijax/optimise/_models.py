"""The light as a function of the variables: dimmers (linear) and aims (through the kernels).

Both models map the flat variable vector ``x`` to ``(E, B, α)``: illuminance at the grid points
(lx), luminous radiosity of the patches (lm/m², None without inter-reflection) and the network
dimmers. Everything is pure JAX and differentiable.

**Dimmers.** Light adds linearly: ``E = α @ E_k`` and ``B = α @ B_k`` with the per-network
solutions at dimmer 1 (the paper's equation 10). No solve, no ray.

**Aims.** Re-aiming a luminaire changes only its direct light; the visibility of its pairs does
not change (the paper, §6). So, once, at the starting aims:

1. the direct stage's own pair set (``lumijax.direct.build_pairs``: the same culling, the same
   sub-sources of large openings, the same shadow rays) is built for the re-aimed luminaires,
   receivers the grid points and the patch centroids, the support cone widened by the largest
   aim change; every pair in it gets a shadow ray;
2. the direct light of the re-aimed luminaires at the start ``D₀`` is taken out of the study's
   solution.

At any aim the direct light is then the one pair kernel (``PairSet.light``, that is
``lumijax.kernels.pair_light``) over the fixed pairs, the kernel the forward light evaluates at
the start aims, and the change of inter-reflected light is one radiosity solve of the change of
patch direct light, ``ΔB = (I − ρF)⁻¹ ρ ΔE_patch``, gathered onto the points, ``G ΔB``. Its
gradient costs one adjoint solve (lineax solves ``(I − ρF)ᵀ`` by implicit differentiation). At
the starting aims the model's direct light is the forward direct light to float precision
(tests/optimise/test_pair_set.py); elsewhere it differs from a full re-computation in four
documented ways: the sub-sources of a large opening keep their start positions (they turn with
the aim about its centre in a re-computation), the LM-63 TILT factor keeps its start value (it
follows the lamp's real tilt in a re-computation: the gain holds it), the change of
inter-reflection is solved in the luminous channel (luminous ρ, not spectral), and what the
mean over a patch near a re-aimed luminaire adds to its centroid's light
(``radiosity/_patch_samples.py``) moves to first order in the aim: lit once at the start with
its tilt and pan slopes (scaled exactly by dimmer and level), lit again where an aims design
re-centres the model (:meth:`AimLight.recentred`). Lit at every aim, the samples cost the demo
2.8× a step and its aims design did not finish in 15 minutes (docs/optimise.md).
``lumijax.optimise`` recomputes the final design exactly.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg
import numpy as np
from jaxtyping import Array, Float, Int

from ..direct import PairSet, build_pairs
from ..radiosity import near_samples
from ..scene._frames import aim_rotation

__all__ = ["DimmerLight", "AimLight", "build_aim_light", "operator_dtype", "DENSE_PATCHES",
           "dense_reflection", "diffuse_coupling", "coupled_b0", "transmission_as"]


class DimmerLight(eqx.Module):
    """``E = α @ total``, ``B = α @ radiosity``: the variables are the network dimmers."""

    total: Float[Array | np.ndarray, "net points"]
    radiosity: Float[Array | np.ndarray, "net patches"] | None

    def recentred(self, x) -> DimmerLight:
        """Itself: superposition is exact at any dimmers (:meth:`AimLight.recentred`)."""
        return self

    def __call__(self, x):
        k = self.total.shape[0]
        alpha = x[:k]
        b = None if self.radiosity is None else alpha @ self.radiosity
        return alpha @ self.total, b, alpha


class AimLight(eqx.Module):
    """The light with some luminaires re-aimed (and/or re-levelled); see the module docstring.

    Variables: ``x = [α (networks), tilt (V), pan (V), level (V)]`` (radians for angles), the
    aim and level blocks present only when optimised. The variables, the fixed parts of the
    light and the result are float64; the pairs and the solve of the inter-reflected change run
    at the study's precision (float32 by default: 776 k pairs cost half the memory traffic).
    """

    base: Float[Array, "net points"]
    base_radiosity: Float[Array, "net patches"] | None
    start_patch: Float[Array, "net patches"] | None
    network: Int[Array, " v"]
    frame: Float[Array, "v 3 3"]
    tilt0: Float[Array, " v"]
    pan0: Float[Array, " v"]
    spin: Float[Array, " v"]
    pairs: tuple[PairSet, ...]
    transport: object | None
    rho: Float[Array, " patches"] | None
    #: LAPACK LU factors ``(lu, piv)`` of the dense, row-corrected ``I − ρFc`` (float64), or
    #: None: small operators are solved by them (:data:`DENSE_PATCHES`), larger ones by the
    #: study's Krylov solve.
    lu: tuple[Float[Array, "patches patches"], Int[Array, " patches"]] | None
    gather_point: Int[Array, " links"] | None
    gather_patch: Int[Array, " links"] | None
    gather_weight: Float[Array, " links"] | None
    n_points: int = eqx.field(static=True)
    n_receivers: int = eqx.field(static=True)
    aims: bool = eqx.field(static=True)
    levels: bool = eqx.field(static=True)
    rtol: float | None = eqx.field(static=True)
    #: Diffusers (``kind = "diffuse"``): each patch's luminous τ and its other face
    #: (:func:`diffuse_coupling`), coupled as the forward solve couples them; None: none.
    tau: Float[Array, " patches"] | None = None
    partner: Int[Array, " patches"] | None = None
    #: The variable luminaires' near pairs (:func:`lumijax.radiosity.near_samples`: a patch
    #: near a luminaire takes its light as the mean over the patch): each pair's luminaire
    #: (index into the variables) and patch, what the mean adds to the centroid's light at unit
    #: weight at the aims ``near_tilt0``/``near_pan0`` (the start's, until :meth:`recentred`),
    #: and its derivatives in tilt and pan there (lx, lx/rad). None: no pair.
    near_var: Int[Array, " pairs"] | None = None
    near_patch: Int[Array, " pairs"] | None = None
    near_start: Float[Array, " pairs"] | None = None
    near_tilt: Float[Array, " pairs"] | None = None
    near_pan: Float[Array, " pairs"] | None = None
    near_tilt0: Float[Array, " v"] | None = None
    near_pan0: Float[Array, " v"] | None = None
    #: The near pairs' samples and pair sets on the host, to light them at other aims
    #: (:meth:`recentred`); None: no pair.
    near_samples: _NearSamples | None = eqx.field(static=True, default=None)

    def trust_region(self, x, lower, upper):
        """Bounds ``(lower, upper)`` on the flat variables with every aim held within
        :data:`TRUST_AIM` of its value in ``x`` (radians): where the first-order light near a
        re-centred luminaire (:meth:`recentred`) stays close to the forward solve's."""
        lower, upper = np.array(lower, np.float64), np.array(upper, np.float64)
        if self.aims:
            k, v = self.base.shape[0], self.n_var
            at = slice(k, k + 2 * v)
            x = np.asarray(x, np.float64)
            lower[at] = np.minimum(np.maximum(lower[at], x[at] - TRUST_AIM), x[at])
            upper[at] = np.maximum(np.minimum(upper[at], x[at] + TRUST_AIM), x[at])
        return lower, upper

    def near_values(self, tilt, pan):
        """Each near pair's addition at unit weight at these aims (lx), to first order about
        ``near_tilt0``/``near_pan0``."""
        return (self.near_start + self.near_tilt * (tilt - self.near_tilt0)[self.near_var]
                + self.near_pan * (pan - self.near_pan0)[self.near_var])

    def patch_light(self, flat, tilt, pan, weight):
        """The patches' direct light (lx) of the variable luminaires at these aims, each
        scaled by ``weight``, from their light ``flat`` on the receivers (points, patches)."""
        on = flat[self.n_points:]
        if self.near_var is None:
            return on
        near = self.near_values(tilt, pan) * weight.astype(on.dtype)[self.near_var]
        return on + jax.ops.segment_sum(near, self.near_patch, num_segments=on.shape[0])

    def recentred(self, x) -> AimLight:
        """This model with its near pairs lit at the aims of ``x`` (flat variables) and moved
        to first order about them: exact there, as at the start (on the host, outside a
        trace). An aims design re-centres it between its rounds (``optimise._standard``)."""
        if self.near_samples is None or not self.aims:
            return self
        _, tilt, pan, _ = self.split(jnp.asarray(x, self.tilt0.dtype))
        tilt, pan = np.asarray(tilt, np.float64), np.asarray(pan, np.float64)
        terms = self.near_samples.terms(self, tilt, pan)
        dt = self.near_start.dtype
        return eqx.tree_at(
            lambda m: (m.near_start, m.near_tilt, m.near_pan, m.near_tilt0, m.near_pan0), self,
            tuple(jnp.asarray(a, dt) for a in (*terms, tilt, pan)))

    @property
    def transmission(self) -> tuple | None:
        """``(tau, partner)`` for ``solve_radiosity``, or None without a diffuser."""
        return None if self.tau is None else (self.tau, self.partner)

    @property
    def n_var(self) -> int:
        return int(self.network.shape[0])

    def split(self, x):
        """``(α, tilt, pan, level)`` from the flat variables (radians)."""
        k, v = self.base.shape[0], self.n_var
        alpha = x[:k]
        i = k
        tilt, pan = self.tilt0, self.pan0
        if self.aims:
            tilt, pan = x[i:i + v], x[i + v:i + 2 * v]
            i += 2 * v
        level = x[i:i + v] if self.levels else jnp.ones_like(self.tilt0)
        return alpha, tilt, pan, level

    def direct(self, tilt, pan, weight):
        """Direct light (lx) on all receivers (points, then patches) of the variable
        luminaires at these aims, each scaled by ``weight``."""
        rot = self.frame @ aim_rotation(tilt, pan, self.spin)
        out = jnp.zeros(self.n_receivers, self.base.dtype)
        for p in self.pairs:
            dt = p.gain.dtype
            e = p.light(rot.astype(dt)) * weight.astype(dt)[p.luminaire]
            out = out + jax.ops.segment_sum(e, p.receiver,
                                            num_segments=self.n_receivers).astype(out.dtype)
        return out

    def __call__(self, x):
        alpha, tilt, pan, level = self.split(x)
        weight = alpha[self.network] * level
        return self._assemble(alpha, self.direct(tilt, pan, weight), tilt, pan, weight)

    def _assemble(self, alpha, flat, tilt, pan, weight):
        """``(E, B, α)`` from the variable luminaires' direct light ``flat`` on the receivers
        at these aims and weights."""
        n = self.n_points
        e = alpha @ self.base + flat[:n]
        b = None
        if self.base_radiosity is not None:
            b = alpha @ self.base_radiosity
        if self.transport is not None:
            d_patch = self.patch_light(flat, tilt, pan, weight) - alpha @ self.start_patch
            db = self.reflect(coupled_b0(self.rho, d_patch, self.transmission)).astype(e.dtype)
            e = e + jax.ops.segment_sum(db[self.gather_patch] * self.gather_weight,
                                        self.gather_point, num_segments=n)
            b = b + db
        return e, b, alpha

    def linearise(self, x):
        """``(E, B, α, pull)``: the light at ``x`` and ``pull(W_e, W_b, W_α) -> W_x``, the
        pull-back of m cotangents at once (rows; ``W_b`` None without patches) onto the flat
        variables: the rows of the Jacobian of anything computed from the light.

        Built on the model's structure rather than ``vmap`` over a reverse pass (measured on the
        demo, 230 re-aimed luminaires: 12 pull-backs of the direct light by ``vmap`` cost 13× its
        forward, of the reflection by the LU under ``vmap`` 10×; benchmarks/design.py):

        * a pair's light depends on its own luminaire's aim only, so two forward tangents (every
          tilt, then every pan, at once) give each pair's ``∂E_p/∂tilt`` and ``∂E_p/∂pan``, and
          a constraint's derivative per luminaire is a segment sum over its pairs;
        * the inter-reflected change is linear, ``ΔB = R ρ ΔE_patch``: its pull-back is one
          solve with ``Rᵀ`` for the m cotangent columns together.
        """
        alpha, tilt, pan, level = self.split(x)
        weight = alpha[self.network] * level
        v, k, nr = self.n_var, self.base.shape[0], self.n_receivers
        per_pair = []
        flat = jnp.zeros(nr, self.base.dtype)
        for p in self.pairs:
            e_p, d_tilt, d_pan = self.pair_tangents(p, tilt, pan)
            per_pair.append((e_p, d_tilt, d_pan))
            e_w = e_p * weight.astype(e_p.dtype)[p.luminaire]
            flat = flat + jax.ops.segment_sum(e_w, p.receiver,
                                              num_segments=nr).astype(flat.dtype)
        e, b, alpha = self._assemble(alpha, flat, tilt, pan, weight)

        def rows_by(w, seg, count):  # (m, items) summed into (m, count) by segment
            return jax.ops.segment_sum(w.T, seg, num_segments=count).T

        def pull(w_e, w_b, w_alpha):
            w_alpha = w_alpha + w_e @ self.base.T
            if self.base_radiosity is not None:
                w_alpha = w_alpha + w_b @ self.base_radiosity.T
            w_flat = w_e
            if self.transport is not None:
                w_db = w_b + rows_by(w_e[:, self.gather_point] * self.gather_weight,
                                     self.gather_patch, self.rho.shape[0])
                r = self.reflect_t(w_db)
                w_d = self.rho * r
                if self.tau is not None:  # the pull-back of B₀'s τ ΔE[partner]
                    w_d = w_d.at[:, self.partner].add(self.tau * r)
                w_alpha = w_alpha - w_d @ self.start_patch.T
                w_flat = jnp.concatenate([w_e, w_d], axis=1)
            w_weight = jnp.zeros((w_e.shape[0], v), e.dtype)
            w_tilt = w_pan = w_weight
            if self.transport is not None and self.near_var is not None:
                w_near = w_d[:, self.near_patch]
                w_weight = rows_by(w_near * self.near_values(tilt, pan), self.near_var, v)
                if self.aims:
                    w_tilt = rows_by(w_near * self.near_tilt, self.near_var, v)
                    w_pan = rows_by(w_near * self.near_pan, self.near_var, v)
            for p, (e_p, d_tilt, d_pan) in zip(self.pairs, per_pair, strict=True):
                w_r = w_flat[:, p.receiver]
                w_weight = w_weight + rows_by(w_r * e_p, p.luminaire, v)
                if self.aims:
                    w_tilt = w_tilt + rows_by(w_r * d_tilt, p.luminaire, v)
                    w_pan = w_pan + rows_by(w_r * d_pan, p.luminaire, v)
            w_alpha = w_alpha + rows_by(w_weight * level, self.network, k)
            out = [w_alpha]
            if self.aims:
                out += [w_tilt * weight, w_pan * weight]
            if self.levels:
                out.append(w_weight * alpha[self.network])
            return jnp.concatenate(out, axis=1)

        return e, b, alpha, pull

    def pair_tangents(self, p: PairSet, tilt, pan):
        """``(E, ∂E/∂tilt, ∂E/∂pan)`` of each pair of ``p`` at unit weight (lx, lx/rad; the
        tangents None without aims): two forward tangents, every tilt then every pan at once,
        as a pair's light depends on its own luminaire's aim only."""
        dt = p.gain.dtype

        def light(t, q):
            return p.light((self.frame @ aim_rotation(t, q, self.spin)).astype(dt))

        if not self.aims:
            return light(tilt, pan), None, None
        e, d_tilt = jax.jvp(light, (tilt, pan), (jnp.ones_like(tilt), jnp.zeros_like(pan)))
        _, d_pan = jax.jvp(light, (tilt, pan), (jnp.zeros_like(tilt), jnp.ones_like(pan)))
        return e, d_tilt, d_pan

    def pull_rows(self, budget_bytes: int | None = None) -> int:
        """Cotangent rows one pull-back of :meth:`linearise` may take at once: each row holds
        numbers per pair (its cotangent on the pair, times the light and both tangents, and
        XLA's temporaries of them) and, with a Krylov reflection, a solve's work vectors per
        patch. Rows beyond this count are pulled back in a sequence of chunks
        (``jax.lax.map``). ``budget_bytes``: a quarter of the available memory
        (``LUMIJAX_MEMORY_BYTES``) by default.

        The 40 float64 numbers a pair a row are measured (8-bay courtyard, 1,632,806 pairs,
        7,264 patches, Krylov, alone): all 37 rows at once peaked at 20.9 GiB (0.51 GB a row,
        39 a pair), chunks of 4 at 3.7 GiB (0.3 GB a row over a 2.5 GiB base)."""
        if budget_bytes is None:
            from ..radiosity._estimate import available_memory_bytes

            budget_bytes = available_memory_bytes() // 4
        pairs = sum(int(p.receiver.shape[0]) for p in self.pairs)
        patches = 0 if self.rho is None else int(self.rho.shape[0])
        krylov = self.transport is not None and self.lu is None
        per_row = 8 * (40 * pairs + (48 if krylov else 4) * patches + 4 * self.n_receivers)
        return max(1, int(budget_bytes // max(per_row, 1)))

    def reflect(self, b0: Float[Array, " patches"]) -> Float[Array, " patches"]:
        """``(I − ρF − τPF)⁻¹ B₀`` (lm/m²; the τ term with diffusers only, ``_transmission.py``)
        with the solve's row correction: by the LU factors when
        the model holds them (a triangular pair forward, the same transposed for the adjoint:
        a Jacobian of m constraints costs m of those, not m Krylov solves under ``vmap``),
        else by the study's Krylov solve."""
        if self.lu is not None:
            return jax.scipy.linalg.lu_solve(self.lu, b0.astype(self.lu[0].dtype))
        from ..radiosity import solve_radiosity

        dt = operator_dtype(self.transport)
        return solve_radiosity(self.transport, self.rho.astype(dt), b0.astype(dt)[:, None],
                               rtol=self.rtol, transmission=transmission_as(self.transmission, dt)
                               ).value[:, 0]

    def reflect_t(self, w: Float[Array, "m patches"]) -> Float[Array, "m patches"]:
        """Rows ``w`` times ``(I − ρF)⁻¹`` (the transposed solve of :meth:`reflect`), m rows at
        once: one LU solve of m columns, else the Krylov solve's reverse pass per row."""
        if self.lu is not None:
            return jax.scipy.linalg.lu_solve(self.lu, w.T.astype(self.lu[0].dtype),
                                             trans=1).T.astype(w.dtype)
        out, pull = jax.vjp(self.reflect, jnp.zeros(self.rho.shape[0], w.dtype))
        # a cotangent has its output's dtype: the operator's (float32 rows for a float32 study)
        return jax.vmap(lambda r: pull(r.astype(out.dtype))[0])(w).astype(w.dtype)


DENSE_PATCHES = 6000
"""Largest coarse patch count whose reflection the aim model factorises densely (float64: 288 MB
at 6,000 patches, an LU of ~1.4·10¹¹ flops once). Measured on the demo (3,490 patches, contended,
benchmarks/RESULTS.md): the constraints' Jacobian by ``vmap`` over Krylov solves took 3.7 s a
step, by the LU 0.X s."""


def dense_reflection(transport, rho, transmission: tuple | None = None) -> tuple[Array, Array]:
    """LU factors of ``I − diag(ρ) F diag(c)``: the system ``solve_radiosity`` solves (its row
    correction ``c``, ``radiosity.row_correction``, folded in: ``B − ρF(cB) = B₀``); with
    ``transmission = (tau, partner)`` (:func:`diffuse_coupling`) that of the coupled solve,
    ``I − (diag(ρ) F + diag(τ) P F) diag(c)``, P the permutation front ↔ back."""
    import scipy.linalg

    from ..radiosity import row_correction

    c, _ = row_correction(transport.row_sums())
    f = transport.todense()
    k = np.asarray(rho, np.float64)[:, None] * f
    if transmission is not None:
        tau, partner = transmission
        k += np.asarray(tau, np.float64)[:, None] * f[np.asarray(partner)]
    k = -k * np.asarray(c, np.float64)[None, :]
    k[np.diag_indices_from(k)] += 1.0
    lu, piv = scipy.linalg.lu_factor(k, overwrite_a=True, check_finite=False)
    return jnp.asarray(lu), jnp.asarray(piv)


def diffuse_coupling(lighting) -> tuple[np.ndarray, np.ndarray] | None:
    """``(tau, partner)``: each coarse patch's luminous diffuse transmittance (``kind =
    "diffuse"``; 0 elsewhere) and the patch of its other face (``radiosity.back_partners``),
    the coupling the forward solve gives its operator and B₀ = ρE + τE[partner]
    (``lighting._spectral``), in the luminous channel the optimiser's solves run in (their ρ is
    ``coarse.rho``); None when no patch transmits diffusely."""
    patches = lighting.coarse.patches
    if patches is None:
        return None
    mats = lighting.scene.materials
    tau = np.array([m.tau if m.diffuse_transmitting else 0.0 for m in mats])[
        np.asarray(patches.material)]
    if not np.any(tau > 0):
        return None
    from ..radiosity import back_partners

    return tau, back_partners(patches, tau > 0)


def coupled_b0(rho, e, transmission):
    """``ρ E + τ E[partner]`` (lm/m²) for patch irradiances ``e`` (lx; patches first), the
    forward solve's B₀; ``ρ E`` without a diffuser (``transmission`` None)."""
    r = rho.reshape(rho.shape + (1,) * (e.ndim - rho.ndim))
    if transmission is None:
        return r * e
    tau, partner = transmission
    t = jnp.asarray(tau).reshape(r.shape)
    return r * e + t * e[jnp.asarray(partner)]


def transmission_as(transmission, dt):
    """``(tau, partner)`` with τ in the solve's precision ``dt`` (None stays None)."""
    return None if transmission is None else (jnp.asarray(transmission[0]).astype(dt),
                                              transmission[1])


TRUST_AIM = float(np.radians(0.5))
"""How far (rad) a tightening round may turn an aim from the design the model was re-centred
at (:meth:`AimLight.trust_region`). At random ±5° aims the demo's first-order light near its
luminaires misjudged its walls by up to 13 % of their peak; the error goes as the square of the
turn, so within 0.5° about 1 % of that."""

_SLOPE_STEP = 1e-3  # rad: the step of the near pairs' central differences

PAIR_THRESHOLD = 1e-4
"""Relative intensity below which a pair's light is kept at its start value (see
:func:`build_aim_light`)."""


def operator_dtype(transport) -> np.dtype:
    """The precision the study's form factors are stored in (that of its solve): solving in
    another would convert every block on every product."""
    if not transport.buckets:
        return np.dtype(transport.area.dtype)
    return np.dtype(transport.buckets[0].dtype)


def build_aim_light(lighting, variable: list[int], tilt_span, pan_span, *, aims: bool,
                    levels: bool, indirect: bool = True, dtype=np.float64,
                    pair_dtype=None, threshold: float = PAIR_THRESHOLD,
                    dense: bool = True) -> AimLight:
    """Precompute pairs, visibility and the start-aim direct light for luminaires ``variable``
    (indices into ``scene.luminaires``).

    ``tilt_span``/``pan_span`` are each luminaire's largest aim change either way (radians):
    the support cone is widened by their sum, which bounds how far the beam axis can turn.
    ``pair_dtype`` is the precision of the pairs (default: the study's, that of its transport
    operator, float64 without one); the inter-reflected change is solved by the dense LU
    (float64) up to :data:`DENSE_PATCHES` patches when ``dense``, else at the operator's
    precision by its Krylov solve.

    A pair enters only if the luminaire's intensity towards the receiver can exceed
    ``threshold`` × its peak at some aim within the bounds (the cone where it does, widened by
    the largest aim change); the other pairs keep their start light (it stays in ``base``), so
    the model is still exact at the start and, away from it, errs by less than ``threshold`` ×
    peak / d² per dropped pair. A Gaussian spot's table reaches 1e-8 of its peak near 77° off
    axis: 0 (every non-zero sample) made every wall point a pair of every spot of the benchmark
    facade (1.48 M pairs); 1e-4 keeps 188 k.
    """
    sc = lighting.scene
    pts = np.asarray(lighting.points, np.float64)
    nrm = np.asarray(lighting.normals, np.float64)
    nrm = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    has_patches = lighting.coarse.patches is not None and indirect
    if has_patches:
        patches = lighting.coarse.patches
        rcv = np.concatenate([pts, patches.centroid])
        rcv_n = np.concatenate([nrm, patches.normal])
    else:
        rcv, rcv_n = pts, nrm
    if pair_dtype is None:
        pair_dtype = (operator_dtype(lighting.transport) if lighting.transport is not None
                      else np.dtype(np.float64))
    n_pts = len(pts)
    lums = [sc.luminaires[i] for i in variable]
    net_index = {n: k for k, n in enumerate(sc.network_names)}
    widen = np.asarray(tilt_span) + np.asarray(pan_span) if aims else np.zeros(len(lums))
    # the direct stage's own pairs (culling, sub-sources, shadow rays), with the support cone
    # widened by the aim range: at the start aims they are the forward light
    pairs, _ = build_pairs(sc, rcv, rcv_n, variable, widen=widen, threshold=threshold,
                           dtype=pair_dtype)
    k = len(sc.networks)
    network = np.array([net_index[lum.network] for lum in lums], np.int32)
    f = jnp.asarray
    model = AimLight(
        base=f(lighting.point_total.astype(dtype)), base_radiosity=None, start_patch=None,
        network=f(network),
        frame=f(np.array([lum.frame_rotation for lum in lums]).reshape(-1, 3, 3).astype(dtype)),
        tilt0=f(np.radians([lum.tilt for lum in lums]).astype(dtype)),
        pan0=f(np.radians([lum.pan for lum in lums]).astype(dtype)),
        spin=f(np.radians([lum.spin for lum in lums]).astype(dtype)),
        pairs=tuple(pairs), transport=None, rho=None, lu=None, gather_point=None,
        gather_patch=None, gather_weight=None, n_points=n_pts, n_receivers=len(rcv), aims=aims,
        levels=levels, rtol=None,
    )
    # the variable luminaires' own direct light at the start, per network: taken out of the
    # study's solution so that the model adds it back at whatever aim
    rot0 = model.frame @ aim_rotation(model.tilt0, model.pan0, model.spin)
    nr = len(rcv)
    start = np.zeros((k, nr))
    for p in pairs:
        e = p.light_stored(rot0)
        flat = network[np.asarray(p.luminaire)].astype(np.int64) * nr + np.asarray(p.receiver)
        start += np.bincount(flat, weights=e, minlength=start.size).reshape(start.shape)
    base = lighting.point_total - start[:, :n_pts]
    fields: dict[str, object] = {"base": f(base.astype(dtype))}
    if lighting.coarse.patches is not None and lighting.coarse.radiosity.size:
        fields["base_radiosity"] = f(np.asarray(lighting.coarse.radiosity, dtype))
    if has_patches:
        g = lighting.coarse.gather
        start_patch = start[:, n_pts:].copy()
        near = _NearSamples.of(sc, patches, variable, widen, threshold)
        if near is not None:
            begin, d_tilt, d_pan = near.terms(model, np.asarray(model.tilt0, np.float64),
                                              np.asarray(model.pan0, np.float64))
            flat = network[near.var].astype(np.int64) * patches.n + near.patch
            start_patch += np.bincount(flat, weights=begin,
                                       minlength=start_patch.size).reshape(start_patch.shape)
            fields.update(near_var=f(near.var.astype(np.int32)),
                          near_patch=f(near.patch.astype(np.int32)),
                          near_start=f(begin.astype(dtype)), near_tilt=f(d_tilt.astype(dtype)),
                          near_pan=f(d_pan.astype(dtype)), near_tilt0=model.tilt0,
                          near_pan0=model.pan0, near_samples=near)
        fields.update(
            start_patch=f(start_patch.astype(dtype)), transport=lighting.transport,
            rho=f(np.asarray(lighting.coarse.rho, dtype)), gather_point=f(g.point),
            gather_patch=f(g.patch), gather_weight=f(np.asarray(g.weight, dtype)),
        )
        coupling = diffuse_coupling(lighting)
        if coupling is not None:
            fields.update(tau=f(coupling[0].astype(dtype)), partner=f(coupling[1], jnp.int32))
        if dense and lighting.transport.n_patches <= DENSE_PATCHES:
            fields["lu"] = dense_reflection(lighting.transport, lighting.coarse.rho, coupling)
    return AimLight(**{**{fd.name: getattr(model, fd.name) for fd in dataclasses.fields(model)},
                       **fields})


class _NearSamples:
    """The variable luminaires' near pairs (:func:`lumijax.radiosity.near_samples`) and their
    samples, paired once by the direct stage (its cone, its shadow rays), kept on the host and
    lit by the stored kernel (``PairSet.light_stored``) at whatever aims :meth:`terms` asks.
    Compared and hashed by identity (it is an :class:`AimLight`'s static field)."""

    def __init__(self, var, patch, owner, weight, sets):
        self.var, self.patch, self.owner, self.weight = var, patch, owner, weight
        self.sets = sets

    @classmethod
    def of(cls, scene, patches, variable, widen, threshold: float) -> _NearSamples | None:
        """The near pairs of the luminaires ``variable`` (indices into ``scene.luminaires``)
        and ``patches``, their samples paired in the support cones widened by ``widen`` (rad:
        lit wherever the model may be re-centred); None without a pair. Lit in float64
        whatever the study's precision: in float32 the slopes' central differences moved the
        optimiser tests' facade's radiosity by 4·10⁻⁵ (tests/optimise/test_gradients.py)."""
        positions = np.array([scene.luminaires[i].position for i in variable],
                             np.float64).reshape(-1, 3)
        near = near_samples(patches, positions)
        if not len(near.luminaire):
            return None
        sets, _ = build_pairs(scene, near.points, near.normals, variable, widen=widen,
                              threshold=threshold, dtype=np.float64,
                              owner=near.luminaire[near.owner])
        return cls(near.luminaire, near.patch, near.owner, near.weight, sets)

    def terms(self, model: AimLight, tilt, pan):
        """``(addition, ∂/∂tilt, ∂/∂pan)`` of each pair at unit weight at these aims (lx,
        lx/rad; radians in): the slopes by central differences of :data:`_SLOPE_STEP` (far
        inside a candela table's cell, far above float64's rounding); zero without aims."""
        frame, spin = np.asarray(model.frame, np.float64), np.asarray(model.spin, np.float64)

        def rotations(t, q):
            return np.asarray(frame @ aim_rotation(t, q, spin))

        h = _SLOPE_STEP
        at = [rotations(tilt, pan)]
        if model.aims:
            at += [rotations(tilt + h, pan), rotations(tilt - h, pan),
                   rotations(tilt, pan + h), rotations(tilt, pan - h)]
        count = len(self.var)
        d = np.zeros((len(at), count))
        for p in self.sets:
            rcv = np.asarray(p.receiver)
            pair, w = self.owner[rcv], self.weight[rcv]
            for row, rot in zip(d, at, strict=True):
                row += np.bincount(pair, weights=w * p.light_stored(rot), minlength=count)
        if not model.aims:
            return d[0], np.zeros(count), np.zeros(count)
        return d[0], (d[1] - d[2]) / (2 * h), (d[3] - d[4]) / (2 * h)
