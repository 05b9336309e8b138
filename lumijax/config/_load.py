"""Read a TOML study config into a validated, frozen :class:`StudyConfig`.

All the ways a config can be wrong end here as one :class:`ConfigError` per problem, naming the
file, the key path (``luminaires[3].aim.tilt``) and what was expected.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from pydantic import ValidationError

from ..errors import ConfigError
from ._schema import StudyConfig
from ._targets import read_target_csv

__all__ = ["load_config", "parse_config"]

# Tags that pydantic puts into error locations for discriminated unions; they are not keys.
_UNION_TAGS = {"box", "rectangle", "mesh", "plane", "points", "photometric", "area", "file",
               "builtin"}


def load_config(path: str | Path) -> StudyConfig:
    """Load and validate a study config from a TOML file.

    Relative paths inside it resolve against the file's own folder.

    Raises
    ------
    ConfigError
        On unreadable or malformed TOML, unknown keys, wrong types or values, missing files and
        dangling references (unknown material, group, photometry or network).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("config file not found", file=path) from None
    except (OSError, UnicodeDecodeError) as e:
        raise ConfigError(f"cannot read config: {e}", file=path) from None
    return parse_config(text, source=path)


def parse_config(text: str, *, source: str | Path | None = None) -> StudyConfig:
    """Validate TOML text as a study config; ``source`` names it in errors and anchors paths."""
    src = Path(source) if source is not None else None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        m = re.search(r"\(at line (\d+), column (\d+)\)", str(e))
        line = int(m.group(1)) if m else None
        msg = re.sub(r"\s*\(at line \d+, column \d+\)", "", str(e))
        raise ConfigError(f"invalid TOML: {msg}", file=src, line=line) from None
    base_dir = src.resolve().parent if src is not None else Path.cwd()
    try:
        cfg = StudyConfig.model_validate(data, context={"base_dir": base_dir})
    except ValidationError as e:
        err = e.errors(include_url=False)[0]
        loc = err["loc"]
        if err["type"] == "missing" and loc and isinstance(loc[-1], int):
            loc = loc[:-1]  # a short [x, y] vector: name the vector, not its missing element
        key = _key_path(loc)
        raise ConfigError(
            _describe(err) + _more(len(e.errors())), file=src, key=key or None,
            line=_find_line(text, key),
        ) from None
    cfg._source = src.resolve() if src is not None else None
    _check_references(cfg, src, text)
    return cfg


def _more(n: int) -> str:
    return f" (and {n - 1} more problem{'s' if n > 2 else ''})" if n > 1 else ""


def _key_path(loc: tuple) -> str:
    """Turn a pydantic error location into a config key path, dropping union tags.

    Pydantic inserts the chosen union member's tag right after a list index (geometry, luminaires,
    grids) or after a photometry entry's name; those are not keys the user wrote.
    """
    out, skip = "", set[int]()
    for i, part in enumerate(loc):
        prev = loc[i - 1] if i else None
        if isinstance(prev, int) and part in _UNION_TAGS and i not in skip:
            continue
        if i >= 2 and loc[i - 2] == "photometry" and part in _UNION_TAGS:
            continue
        if isinstance(part, str) and ("[" in part or "(" in part):
            continue  # a union member pydantic tried ('function-after[_finite(), float]')
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out


def _describe(err: dict) -> str:
    typ, msg, inp = err["type"], err["msg"], err.get("input")
    if isinstance(inp, float) and inp != inp or inp in (float("inf"), float("-inf")):
        # TOML has nan and inf; a bound test on them would read "greater than 0, got nan"
        return f"expected a finite number, got {inp!r}"
    if typ == "extra_forbidden":
        return "unknown key (check its spelling against docs/config.md)"
    if typ == "missing" and isinstance(err["loc"][-1], int):
        return "expected a list of 3 numbers [x, y, z]"
    if typ == "missing":
        return "required key is missing"
    if typ == "union_tag_invalid":
        expected = err.get("ctx", {}).get("expected_tags", "")
        kind = inp.get("kind") if isinstance(inp, dict) else inp
        return f"unknown kind {kind!r}; expected one of {expected}"
    if typ == "union_tag_not_found":
        return "missing 'kind'"
    if typ == "literal_error":
        return f"got {inp!r}; expected {err.get('ctx', {}).get('expected', '')}"
    if typ in ("float_parsing", "float_type", "int_parsing", "int_type", "int_from_float"):
        return f"expected a {'whole ' if 'int' in typ else ''}number, got {inp!r}"
    if typ in ("tuple_type", "too_short", "too_long", "list_type") and "tuple" in msg.lower():
        return f"expected a list of 3 numbers [x, y, z], got {inp!r}"
    if typ == "too_long" or typ == "too_short":
        return f"{msg.lower()}; got {inp!r}"
    if typ == "value_error":
        return msg.removeprefix("Value error, ")
    if typ == "string_pattern_mismatch":
        return f"{inp!r} is not a valid name: use letters, digits, '_', '-' and '.'"
    text = msg[0].lower() + msg[1:]
    return f"{text}, got {inp!r}" if inp is not None and not isinstance(inp, dict) else text


def _find_line(text: str, key: str) -> int | None:
    """Best-effort line of the last component of ``key`` (for editors that jump to lines)."""
    if not key:
        return None
    parts = re.findall(r"[^.\[\]]+|\[\d+\]", key)
    lines = text.splitlines()
    start = 0
    table = None  # the line of a [table] the key's last part names (a model-level error)
    # walk array-of-tables headers: 'luminaires[3]' is the 4th [[luminaires]] header
    for j, p in enumerate(parts):
        if p.startswith("[") and j > 0:
            name, idx = parts[j - 1], int(p[1:-1])
            hits = [i for i, ln in enumerate(lines) if ln.strip() == f"[[{name}]]"]
            if idx < len(hits):
                start = hits[idx]
        elif j == 0 or not parts[j - 1].startswith("["):
            hdr = [i for i, ln in enumerate(lines[start:], start)
                   if re.match(rf"^\s*\[+[^\]]*\b{re.escape(p)}\b[^\]]*\]+\s*$", ln)]
            if hdr and j < len(parts) - 1:
                start = hdr[0]
            elif hdr:
                table = hdr[0]
    while parts and parts[-1].startswith("[") and len(parts) > 1 and not parts[-2].startswith("["):
        parts = parts[:-1]  # 'min[2]': the element of an inline array is on the 'min' line
    last = parts[-1]
    if last.startswith("["):
        return start + 1 if start else None
    for i in range(start, len(lines)):
        if i > start and lines[i].lstrip().startswith("[") and i != start:
            break
        if re.match(rf"^\s*{re.escape(last)}\s*=", lines[i]) or re.search(
            rf"[{{,]\s*{re.escape(last)}\s*=", lines[i]
        ):
            return i + 1
    if table is not None:
        return table + 1
    return start + 1 if start else None


def _check_references(cfg: StudyConfig, src: Path | None, text: str) -> None:
    def fail(key: str, msg: str) -> None:
        raise ConfigError(msg, file=src, key=key, line=_find_line(text, key))

    def known(kind: str, names) -> str:
        names = sorted(names)
        return f"declared {kind}: {', '.join(names)}" if names else f"no {kind} are declared"

    for name, g in cfg.groups.items():
        if g.parent is not None and g.parent not in cfg.groups:
            fail(f"groups.{name}.parent", f"unknown group {g.parent!r}; {known('groups', cfg.groups)}")
        seen, cur = {name}, g.parent
        while cur is not None:
            if cur in seen:
                fail(f"groups.{name}.parent", f"group parents form a cycle through {cur!r}")
            seen.add(cur)
            cur = cfg.groups[cur].parent

    def check_group(key: str, group: str | None) -> None:
        if group is not None and group not in cfg.groups:
            fail(key, f"unknown group {group!r}; {known('groups', cfg.groups)}")

    for i, g in enumerate(cfg.geometry):
        if g.material not in cfg.materials:
            fail(f"geometry[{i}].material",
                 f"unknown material {g.material!r}; {known('materials', cfg.materials)}")
        check_group(f"geometry[{i}].group", g.group)

    names: dict[str, int] = {}
    for i, lum in enumerate(cfg.luminaires):
        if lum.name in names:
            fail(f"luminaires[{i}].name",
                 f"duplicate luminaire name {lum.name!r} (also luminaires[{names[lum.name]}])")
        names[lum.name] = i
        check_group(f"luminaires[{i}].group", lum.group)
        if lum.kind == "photometric" and lum.photometry not in cfg.photometry:
            fail(f"luminaires[{i}].photometry",
                 f"unknown photometry {lum.photometry!r}; {known('photometry', cfg.photometry)}")
        if cfg.networks and lum.network not in cfg.networks:
            fail(f"luminaires[{i}].network",
                 f"unknown network {lum.network!r}; {known('networks', cfg.networks)}")

    grid_names: dict[str, int] = {}
    for i, g in enumerate(cfg.grids):
        if g.name in grid_names:
            fail(f"grids[{i}].name",
                 f"duplicate grid name {g.name!r} (also grids[{grid_names[g.name]}])")
        grid_names[g.name] = i
        check_group(f"grids[{i}].group", g.group)
    _check_optimise(cfg, fail)
    from ._observers import check_observers  # _schema imports _observers: loaded by now

    check_observers(cfg, fail)
    from ._compliance import check_compliance  # _schema imports _compliance: loaded by now

    check_compliance(cfg, fail)


def _grid_size(g) -> int:
    """Points of a grid, as the scene will build it (lumijax.scene._grid)."""
    import math

    from ._schema import grid_count

    if g.kind == "points":
        return len(g.points)
    if g.spacing is not None:  # finite: the schema refused counts beyond MAX_GRID_POINTS
        return int(grid_count(math.hypot(*g.u), g.spacing) * grid_count(math.hypot(*g.v),
                                                                          g.spacing))
    return g.nu * g.nv


def _check_optimise(cfg: StudyConfig, fail) -> None:
    """``[optimise]`` and the per-grid targets: something to aim at, CSV maps that fit."""
    for i, g in enumerate(cfg.grids):
        if g.target_csv is None:
            continue
        key = f"grids[{i}].target_csv"
        rows = read_target_csv(g.target_csv, key=key)
        n = _grid_size(g)
        if len(rows) != n:
            fail(key, f"{g.target_csv.name} has {len(rows)} rows but grid {g.name!r} has {n} "
                      "points: give one row (x, y, z, lux) per grid point, in the grid's order")
    opt = cfg.optimise
    if opt is None:
        return
    wants = [g for g in cfg.grids if g.target_lux is not None or g.target_csv is not None
             or g.min_lux is not None or g.max_lux is not None or g.uniformity_min is not None
             or g.max_luminance_cdm2 is not None]
    if (not wants and opt.max_luminance_cdm2 is None and opt.energy_weight == 0
            and not opt.constraints):  # [[optimise.constraints]] are goals too
        fail("optimise", "nothing to optimise: give a grid a target (target_lux, target_csv, "
                         "min_lux, max_lux, uniformity_min or max_luminance_cdm2), "
                         "[optimise] max_luminance_cdm2 or energy_weight")
    if "levels" in opt.variables and "dimmers" not in opt.variables:
        fail("optimise.variables", "'levels' scale luminaires within their network: "
                                   "optimise 'dimmers' too")
    photometric = [lum for lum in cfg.luminaires if lum.kind == "photometric"]
    for var in ("aims", "levels"):
        if var in opt.variables and not photometric:
            fail("optimise.variables", f"{var!r} are fitted on photometric luminaires and the "
                                       "study has none (area sources cannot be aimed or "
                                       f"levelled): remove {var!r}")
    free = []  # what the fit may change: a box lo < hi on at least one variable
    if opt.dimmer_min < 1 and cfg.luminaires:
        free += [v for v in ("dimmers", "levels") if v in opt.variables]
    if "aims" in opt.variables and any(
            lo < hi for lum in photometric for lo, hi in _aim_ranges(cfg, lum, opt)):
        free.append("aims")
    if not free:
        why = []
        if not cfg.luminaires:
            why.append("the study has no luminaire")
        elif {"dimmers", "levels"} & set(opt.variables):
            why.append(f"dimmer_min = {opt.dimmer_min:g} pins every dimmer and level at 1")
        if "aims" in opt.variables and photometric:
            why.append("every aim range (tilt_range_deg, pan_range_deg, aim_range_deg) is a "
                       "single angle")
        only_dimmer_min = cfg.luminaires and "aims" not in opt.variables
        fail("optimise.dimmer_min" if only_dimmer_min else "optimise.variables",
             f"nothing can change: {' and '.join(why)}; give the optimiser a range to move in")


def _aim_ranges(cfg: StudyConfig, lum, opt):
    """(tilt, pan) ranges in degrees of a luminaire: its own, then its groups', then
    ``[optimise]`` (as lumijax.optimise resolves them)."""
    ranges = [lum.aim_range_deg]
    g = lum.group
    while g is not None:
        ranges.append(cfg.groups[g].aim_range_deg)
        g = cfg.groups[g].parent
    return [next((getattr(r, comp) for r in ranges if r is not None
                  and getattr(r, comp) is not None), default)
            for comp, default in (("tilt", opt.tilt_range_deg), ("pan", opt.pan_range_deg))]
