"""Write the optimised study back as TOML: the designer's own file, comments kept, with the new
dimmers, aims and levels of a :class:`~lumijax.design.Design`, and relative paths re-anchored
at the new file's folder. Output for the designer only: lumijax never parses it back to get
results (``results.at(design)`` lights the design directly)."""

from __future__ import annotations

import os
from pathlib import Path

from ..config import FilePhotometry

__all__ = ["optimised_toml"]


def _source_text(cfg) -> str:
    import tomlkit

    if cfg.source is not None and Path(cfg.source).is_file():
        return Path(cfg.source).read_text(encoding="utf-8")
    # a config parsed from text: rebuild it from the validated model (defaults written out)
    return tomlkit.dumps(cfg.model_dump(mode="json", exclude_none=True))


def _rel(path: Path, base: Path | None) -> str:
    if base is None:
        return str(path)
    try:
        return Path(os.path.relpath(path, base)).as_posix()
    except ValueError:  # another drive on Windows
        return str(path)


def optimised_toml(cfg, design, *, aimed=(), levelled=(), base_dir: Path | None,
                   note: str = "") -> str:
    """The config text at ``design``.

    Every network's dimmer is written (6 decimals); the aims of the luminaires named in
    ``aimed`` as ``{tilt, pan, spin}`` in degrees, in the luminaire's group frame (4 decimals;
    an ``aim_at`` is replaced by the aim it stood for); for those in ``levelled`` the
    ``multiplier`` times the design's level (6 decimals). ``base_dir`` is the folder the text
    will live in: file paths are rewritten relative to it (None: absolute paths).
    """
    import tomlkit

    dimmers = design.dimmer_of()
    aims = {n: design.aim_of(n) for n in aimed}
    levels = {n: design.level_of(n) for n in levelled}
    doc = tomlkit.parse(_source_text(cfg))
    if dimmers:
        if "networks" not in doc:
            doc["networks"] = tomlkit.table(is_super_table=True)
        nets = doc["networks"]
        for name, level in dimmers.items():
            if name not in nets:
                nets[name] = tomlkit.table()
            nets[name]["dimmer"] = round(float(level), 6)
    index = {lum.name: i for i, lum in enumerate(cfg.luminaires)}
    lums = doc.get("luminaires")
    for name, aim in aims.items():
        t = lums[index[name]]
        if "aim_at" in t:
            del t["aim_at"]
        inline = tomlkit.inline_table()
        inline.update({k: round(float(aim[k]), 4) for k in ("tilt", "pan", "spin")})
        t["aim"] = inline
    for name, level in levels.items():
        t = lums[index[name]]
        t["multiplier"] = round(float(cfg.luminaires[index[name]].multiplier * level), 6)
    # file paths: the validated config holds them resolved; write them for the new folder
    for name, p in cfg.photometry.items():
        if isinstance(p, FilePhotometry):
            doc["photometry"][name]["file"] = _rel(p.file, base_dir)
    for i, g in enumerate(cfg.geometry):
        if g.kind == "mesh":
            doc["geometry"][i]["file"] = _rel(g.file, base_dir)
    for name, m in cfg.materials.items():
        if isinstance(m.reflectance, Path):
            doc["materials"][name]["reflectance"] = _rel(m.reflectance, base_dir)
    for i, lum in enumerate(cfg.luminaires):
        if isinstance(lum.spectrum, Path):
            lums[i]["spectrum"] = _rel(lum.spectrum, base_dir)
    for i, g in enumerate(cfg.grids):
        if g.target_csv is not None:
            doc["grids"][i]["target_csv"] = _rel(g.target_csv, base_dir)
    head = "".join(f"# {line}\n" for line in note.splitlines()) if note else ""
    return head + tomlkit.dumps(doc)
