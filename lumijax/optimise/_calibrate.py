"""Calibration to measured illuminance (commissioning): fit light-loss factors per network and
material reflectances so that the model matches the built installation (docs/optimise.md,
"Calibration").

Measurements are a CSV with header ``x,y,z,nx,ny,nz,lux`` (m, unit normal, lx), taken at grid
points of the study (each row is matched to the nearest grid point within ``tolerance_m`` and
a normal within 8°; a row at no grid point is a :class:`ConfigError` naming the file and line).

The model: ``E_i(θ) = Σ_k α_k f_k (D_ki + [G B_k(ρ)]_i)``, the per-network direct light ``D``
of the computed study, the light-loss factor ``f_k`` of network k and the inter-reflected light
solved at the material reflectances ρ (luminous channel, one column per network, through the
radiosity solve: its Jacobian by JAX). The fit is bounded Gauss–Newton (scipy's
``least_squares``, trust-region reflective) on relative residuals ``(E_i − M_i) / M_i``;
uncertainties are ``σ_θ = √diag(s² (JᵀJ)⁻¹)`` with ``s² = Σr² / (m − p)`` at the optimum.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ConfigError
from ..lighting._solution import float64_scope

__all__ = ["Calibration", "calibrate", "read_measurements", "RHO_BOUNDS", "LLF_BOUNDS"]

RHO_BOUNDS = (0.01, 0.95)
"""Physical bounds of a fitted luminous reflectance."""
LLF_BOUNDS = (0.05, 2.0)
"""Bounds of a fitted light-loss factor (above 1: more light than the model's rated flux)."""


def read_measurements(path, grids_points, grids_normals, *, tolerance_m: float = 0.05):
    """``(index, lux)``: each row's grid point (into the concatenated grid points) and its
    measured lux; rows off every grid point, with a normal > 8° off, or unreadable are
    :class:`ConfigError` naming the file and line."""
    path = Path(path)
    key = "calibration.csv"
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise ConfigError(f"cannot read the measurements: {e.strerror}", file=path,
                          key=key) from None
    lines = [ln for ln in text.splitlines()]
    if not lines or [h.strip().lower() for h in lines[0].split(",")] != [
            "x", "y", "z", "nx", "ny", "nz", "lux"]:
        raise ConfigError("expected the header x,y,z,nx,ny,nz,lux", file=path, key=key, line=1)
    pts = np.asarray(grids_points, np.float64)
    nrm = np.asarray(grids_normals, np.float64)
    index, lux = [], []
    for i, ln in enumerate(lines[1:], start=2):
        if not ln.strip():
            continue
        try:
            v = np.array([float(t) for t in ln.split(",")])
        except ValueError:
            raise ConfigError("expected 7 numbers", file=path, key=key, line=i) from None
        if v.shape != (7,) or not np.all(np.isfinite(v)):
            raise ConfigError("expected 7 finite numbers", file=path, key=key, line=i)
        if v[6] <= 0:
            raise ConfigError(f"a measured illuminance must be > 0 lx, got {v[6]:g}",
                              file=path, key=key, line=i)
        d = np.linalg.norm(pts - v[:3], axis=1)
        j = int(np.argmin(d))
        if d[j] > tolerance_m:
            raise ConfigError(
                f"the point {v[:3].round(3).tolist()} lies at no grid point of the study "
                f"(nearest {d[j]:.3g} m away, tolerance {tolerance_m:g} m): measure at the "
                "grids' points, or add a grid there", file=path, key=key, line=i)
        n = v[3:6] / max(np.linalg.norm(v[3:6]), 1e-300)
        if float(n @ nrm[j]) < np.cos(np.radians(8.0)):
            raise ConfigError(f"the normal {v[3:6].round(3).tolist()} is not the grid's "
                              f"{nrm[j].round(3).tolist()} at that point", file=path, key=key,
                              line=i)
        index.append(j)
        lux.append(v[6])
    if not index:
        raise ConfigError("no measurements in the file", file=path, key=key)
    return np.asarray(index), np.asarray(lux)


@dataclass
class Calibration:
    """The fitted parameters (``llf`` per network, ``reflectance`` per material) with their
    standard uncertainties, the residuals (relative, per measurement) before and after, and
    the calibrated study as TOML (:meth:`config_text`)."""

    llf: dict[str, float]
    llf_sigma: dict[str, float]
    reflectance: dict[str, float]
    reflectance_sigma: dict[str, float]
    residuals_before: np.ndarray
    residuals_after: np.ndarray
    rms_before: float
    rms_after: float
    iterations: int
    config: object = field(default=None, repr=False)

    def to_dict(self) -> dict:
        return {"llf": self.llf, "llf_sigma": self.llf_sigma,
                "reflectance": self.reflectance, "reflectance_sigma": self.reflectance_sigma,
                "rms_relative_residual_before": self.rms_before,
                "rms_relative_residual_after": self.rms_after, "iterations": self.iterations}

    def config_text(self) -> str:
        """The study's TOML with the fitted reflectances (materials given by a number) and
        each network's light-loss factor folded into its luminaires' ``maintenance_factor``
        (into ``multiplier`` where the product would exceed 1); comments kept."""
        import tomlkit

        cfg = self.config
        doc = tomlkit.parse(Path(cfg.source).read_text(encoding="utf-8"))
        for name, rho in self.reflectance.items():
            mats = doc.get("materials", {})
            if name in mats and not isinstance(mats[name].get("reflectance"), dict | list):
                mats[name]["reflectance"] = round(float(rho), 4)
        for lum_doc, lum in zip(doc.get("luminaires", []), cfg.luminaires, strict=False):
            f = self.llf.get(lum.network)
            if f is None:
                continue
            mf = float(lum.maintenance_factor) * f
            if mf <= 1.0:
                lum_doc["maintenance_factor"] = round(mf, 4)
            else:
                lum_doc["maintenance_factor"] = 1.0
                mult = float(getattr(lum, "multiplier", 1.0)) * mf
                lum_doc["multiplier"] = round(mult, 4)
        return tomlkit.dumps(doc)

    def write_config(self, path) -> Path:
        from .._atomic import atomic_write_text

        path = Path(path)
        atomic_write_text(path, self.config_text())
        return path


@float64_scope()
def calibrate(study, results, measurements, *, fit=("llf", "reflectance"),
              tolerance_m: float = 0.05) -> Calibration:
    """Fit light-loss factors per network and/or material reflectances to measured lux (see
    the module docstring). ``measurements`` is the CSV path."""
    from scipy.optimize import least_squares

    from ..radiosity import solve_radiosity
    from ._models import coupled_b0, diffuse_coupling, operator_dtype, transmission_as

    unknown = [f for f in fit if f not in ("llf", "reflectance")]
    if unknown or not fit:
        raise ConfigError(f"expected 'llf' and/or 'reflectance' to fit, got {list(fit)}",
                          key="calibration.fit")
    lighting = results.lighting
    idx, meas = read_measurements(measurements, lighting.points, lighting.normals,
                                  tolerance_m=tolerance_m)
    sc = lighting.scene
    alpha = np.asarray(results.design.dimmers, np.float64)
    k = len(alpha)
    coarse = lighting.coarse
    fit_rho = "reflectance" in fit
    if fit_rho and (coarse.patches is None or lighting.transport is None
                    or lighting.fine is not None):
        raise ConfigError("reflectances are fitted through the radiosity solve: the study "
                          "needs inter-reflection with one level of patches",
                          key="calibration.fit")
    direct = jnp.asarray(np.asarray(lighting.point_direct, np.float64)[:, idx])
    if coarse.patches is not None and lighting.transport is not None:
        mat = np.asarray(coarse.patches.material)
        used = np.unique(mat)
        where = jnp.asarray(np.searchsorted(used, mat))
        rho0 = np.array([sc.materials[int(m)].luminous_reflectance for m in used])
        # the per-patch reflectance as a per-material value times each patch's own ratio
        # (patches of a material can differ where a spectral ρ was sampled; luminous here)
        ratio = jnp.asarray(np.asarray(coarse.rho, np.float64) / np.maximum(
            rho0[np.searchsorted(used, mat)], 1e-12))
        e_patch = jnp.asarray(np.asarray(coarse.patch_direct, np.float64).T)  # (P, K)
        g = coarse.gather
        sel = np.isin(np.asarray(g.point), idx)
        remap = -np.ones(len(lighting.points), np.int64)
        remap[idx] = np.arange(len(idx))  # a point measured twice: the last row's slot
        gp = jnp.asarray(remap[np.asarray(g.point)[sel]])
        gq = jnp.asarray(np.asarray(g.patch)[sel])
        gw = jnp.asarray(np.asarray(g.weight, np.float64)[sel])
        dt = operator_dtype(lighting.transport)
        coupling = diffuse_coupling(lighting)  # diffusers: the forward solve's τ coupling
        indirect_fixed = None
    else:
        used, rho0 = np.zeros(0, int), np.zeros(0)
        coupling = None
        indirect_fixed = jnp.asarray(np.asarray(lighting.point_indirect, np.float64)[:, idx])
    n_llf = k if "llf" in fit else 0
    n_rho = len(used) if fit_rho else 0
    # measurement rows that share a point: each row is its own residual at that point
    rows = np.arange(len(idx))
    slot = jnp.asarray(remap[idx] if indirect_fixed is None else rows)

    def model(theta, transport):
        llf = theta[:n_llf] if n_llf else jnp.ones(k)
        if indirect_fixed is not None:
            ind = indirect_fixed
        else:
            rho_m = theta[n_llf:n_llf + n_rho] if n_rho else jnp.asarray(rho0)
            rho = rho_m[where] * ratio
            b = solve_radiosity(transport, rho.astype(dt),
                                coupled_b0(rho, e_patch, coupling).astype(dt),
                                transmission=transmission_as(coupling, dt)).value.astype(jnp.float64)
            ind = jax.vmap(lambda col: jax.ops.segment_sum(col[gq] * gw, gp,
                                                           num_segments=len(idx)),
                           in_axes=1)(b)[:, slot]
        return (alpha * llf) @ (direct + ind)

    m = jnp.asarray(meas)

    def resid(theta, transport):
        return (model(theta, transport) - m) / m

    theta0 = np.concatenate([np.ones(n_llf), rho0 if n_rho else np.zeros(0)])
    lo = np.concatenate([np.full(n_llf, LLF_BOUNDS[0]), np.full(n_rho, RHO_BOUNDS[0])])
    hi = np.concatenate([np.full(n_llf, LLF_BOUNDS[1]), np.full(n_rho, RHO_BOUNDS[1])])
    theta0 = np.clip(theta0, lo, hi)
    # the operator is an argument, not a closed-over constant: as a constant XLA folds its
    # blocks into the program (3 GB and climbing for a 1,000-patch room)
    op = lighting.transport if indirect_fixed is None else None
    r_fn = eqx.filter_jit(resid)
    j_fn = eqx.filter_jit(jax.jacfwd(resid))  # few parameters: forward mode, one solve each
    res = least_squares(lambda t: np.asarray(r_fn(jnp.asarray(t), op)),
                        theta0, jac=lambda t: np.asarray(j_fn(jnp.asarray(t), op)),
                        bounds=(lo, hi), method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    r0 = np.asarray(r_fn(jnp.asarray(theta0), op))
    r1 = np.asarray(res.fun)
    jac = np.asarray(res.jac)
    dof = max(len(r1) - len(theta0), 1)
    s2 = float(r1 @ r1) / dof
    try:
        cov = s2 * np.linalg.inv(jac.T @ jac)
        sigma = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        sigma = np.full(len(theta0), np.inf)
    nets = results.design.networks
    names = [sc.materials[int(mm)].name for mm in used] if n_rho else []
    th = np.asarray(res.x)
    return Calibration(
        llf={n: float(th[i]) for i, n in enumerate(nets)} if n_llf else {},
        llf_sigma={n: float(sigma[i]) for i, n in enumerate(nets)} if n_llf else {},
        reflectance={n: float(th[n_llf + i]) for i, n in enumerate(names)},
        reflectance_sigma={n: float(sigma[n_llf + i]) for i, n in enumerate(names)},
        residuals_before=r0, residuals_after=r1, rms_before=float(np.sqrt(np.mean(r0 ** 2))),
        rms_after=float(np.sqrt(np.mean(r1 ** 2))), iterations=int(res.nfev),
        config=study.config)
