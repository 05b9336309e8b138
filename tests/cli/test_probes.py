"""Hostile inputs through the command line: each ends in exit 1 and one line naming the key (or
the file) and what was expected — never a traceback, never exit 0 with wrong light.

Every row: a change to a small valid study, the command, the exit status, and a substring the
error line must hold (the key path, or the file the problem is in). The runs that succeed are
checked against what the geometry implies (a lamp inside a closed box lights nothing outside).
"""

from __future__ import annotations

import json
import textwrap

import numpy as np
import pytest
from helpers import box_room

from lumijax.cli import main

BASE = box_room("indirect = false\ncache = false", name="probe", networks=("a",))
RECT = '\n[[geometry]]\nkind = "rectangle"\nmaterial = "wall"\norigin = [1, 1, 1]\n'
MESH = '\n[[geometry]]\nkind = "mesh"\nmaterial = "wall"\n'
AREA = ('kind = "area"\norigin = [1, 1, 2.9]\nu = [0.5, 0, 0]\nv = [0, -0.5, 0]\n'
        'flux_lm = 1000')
FILES = {
    "bad.obj": "v 0 0 0\nthis is not a mesh\n",
    "flat.obj": "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
    "nan.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nf 1 2 3\nf 1 2 4\n",
    "huge.obj": "v 0 0 0\nv 1e300 0 0\nv 0 1 0\nf 1 2 3\n",
    "bad.ies": "not an ies file\n",
    "short.csv": "x,y,z,lux\n1,1,1,5\n",
}


def sub(old: str, new: str, text: str = BASE) -> str:
    assert text.count(old) == 1, old
    return text.replace(old, new)


def target(extra: str = "target_lux = 100", text: str = BASE) -> str:
    return sub("nv = 6", f"nv = 6\n{extra}", text)


INDIRECT = sub("indirect = false", "indirect = true")

# name: (study text, expected exit status, substring of the error line)
CHECK = {
    # keys and types
    "unknown_table": (BASE + "[studdy]\nname = 'x'\n", 1, "studdy: unknown key"),
    "wrong_type": (sub("dimmer = 0.5", 'dimmer = "high"'), 1, "networks.a.dimmer: expected a number"),
    "empty_position": (sub("position = [1, 1.5, 2.5]", "position = []"), 1,
                       "luminaires[0].position: expected a list of 3 numbers"),
    "empty_points": (BASE + '[[grids]]\nname = "p"\nkind = "points"\npoints = []\n', 1,
                     "grids[1].points"),
    "nu_zero": (sub("nu = 8", "nu = 0"), 1, "grids[0].nu"),
    "nu_float": (sub("nu = 8", "nu = 1.5"), 1, "grids[0].nu: expected a whole number"),
    "bad_name": (sub('name = "A1"', 'name = "A 1!"'), 1, "luminaires[0].name"),
    "duplicate_table": (BASE + "[networks.a]\ndimmer = 1\n", 1, "invalid TOML"),
    "bad_units": (BASE + MESH + 'file = "flat.obj"\nunits = "km"\n', 1, "geometry[1].units"),
    "bad_solver": (target() + '[optimise]\nsolver = "newton"\n', 1, "optimise.solver"),
    "no_variables": (target() + "[optimise]\nvariables = []\n", 1, "optimise.variables"),
    # zero-area and degenerate geometry
    "zero_rectangle": (BASE + RECT + "u = [0, 0, 0]\nv = [0, 1, 0]\n", 1,
                       "geometry[1]: 'u' and 'v' are parallel or zero"),
    "flat_box": (sub("max = [4, 3, 3]", "max = [4, 3, 0]"), 1, "geometry[0]: box 'max'"),
    "tiny_area_source": (BASE + f'[[luminaires]]\nname = "S"\n{AREA}\nnetwork = "a"\n'.replace(
        "[0.5, 0, 0]", "[1e-200, 0, 0]"), 1, "luminaires[1]: 'u' and 'v' are parallel"),
    "zero_normal": (target("normal = [0, 0, 0]"), 1, "grids[0].normal"),
    "aim_at_self": (sub('network = "a"', 'network = "a"\naim_at = [1, 1.5, 2.5]'), 1,
                    "luminaires[0]: 'aim_at' is the luminaire's own position"),
    "camera_at_target": (BASE + "[cameras.c]\nposition = [1, 1, 1]\ntarget = [1, 1, 1]\n", 1,
                         "cameras.c"),
    # files that are not what they claim
    "mesh_not_a_mesh": (BASE + MESH + 'file = "bad.obj"\n', 1, "bad.obj"),
    "mesh_directory": (BASE + MESH + 'file = "adir"\n', 1, "geometry[1].file: file not found"),
    "mesh_missing": (BASE + MESH + 'file = "nowhere.obj"\n', 1, "geometry[1].file"),
    "mesh_degenerate": (BASE + MESH + 'file = "flat.obj"\n', 1, "flat.obj"),
    "mesh_nan_vertex": (BASE + MESH + 'file = "nan.obj"\n', 1, "nan.obj"),
    "mesh_huge_vertex": (BASE + MESH + 'file = "huge.obj"\n', 1, "geometry[1].file: huge.obj"),
    "photometry_missing": (BASE + '[photometry.f]\nfile = "nowhere.ies"\n', 1,
                           "photometry.f.file: file not found"),
    "photometry_garbage": (BASE + '[photometry.f]\nfile = "bad.ies"\n', 1, "bad.ies"),
    "photometry_directory": (BASE + '[photometry.f]\nfile = "adir"\n', 1, "photometry.f.file"),
    "target_csv_rows": (target('target_csv = "short.csv"'), 1, "grids[0].target_csv"),
    # NaN and inf are valid TOML
    "nan_position": (sub("[1, 1.5, 2.5]", "[nan, 1.5, 2.5]"), 1,
                     "luminaires[0].position[0]: expected a finite number, got nan"),
    "inf_position": (sub("[1, 1.5, 2.5]", "[inf, 1.5, 2.5]"), 1, "got inf"),
    "nan_dimmer": (sub("dimmer = 0.5", "dimmer = nan"), 1, "networks.a.dimmer: expected a finite"),
    "nan_reflectance": (sub("reflectance = 0.5", "reflectance = nan"), 1,
                        "materials.wall.reflectance: expected a finite number"),
    "nan_rotate": (BASE + "[groups.g]\nrotate = [nan, 0, 0]\n", 1, "groups.g.rotate[0]"),
    "nan_normal": (BASE + '[[grids]]\nname = "p"\nkind = "points"\npoints = [[1, 1, 1]]\n'
                   'normals = [[nan, 0, 1]]\n', 1, "grids[1].normals[0][0]: expected a finite"),
    "nan_target": (target("target_lux = nan") + "[optimise]\n", 1, "grids[0].target_lux"),
    # out-of-range and huge numbers
    "negative_dimmer": (sub("dimmer = 0.5", "dimmer = -0.5"), 1, "networks.a.dimmer"),
    "zero_flux": (sub("flux_lm = 2000", "flux_lm = 0"), 1, "photometry.iso.flux_lm"),
    "huge_flux": (sub("flux_lm = 2000", "flux_lm = 1e300"), 1, "photometry.iso.flux_lm"),
    "huge_box": (sub("max = [4, 3, 3]", "max = [1e300, 3, 3]"), 1, "geometry[0].max[0]"),
    "grid_far_away": (sub("origin = [0, 0, 0.01]", "origin = [1e300, 0, 10]"), 1,
                      "grids[0].origin[0]"),
    "huge_tilt": (sub('network = "a"', 'network = "a"\naim = { tilt = 1e308 }'), 1,
                  "luminaires[0].aim.tilt"),
    "huge_target": (target("target_lux = 1e308") + "[optimise]\n", 1, "grids[0].target_lux"),
    "huge_multiplier": (sub('network = "a"', 'network = "a"\nmultiplier = 1e300'), 1,
                        "luminaires[0].multiplier"),
    "zero_spacing": (sub("nu = 8\nnv = 6", "spacing = 0"), 1, "grids[0].spacing"),
    "tiny_spacing": (sub("nu = 8\nnv = 6", "spacing = 1e-300"), 1, "grids[0].spacing"),
    "many_points": (sub("nu = 8\nnv = 6", "nu = 100000\nnv = 100000"), 1, "grids[0].nv"),
    "few_patches": (sub("cache = false", "cache = false\ntarget_patches = 5"), 1,
                    "solver.target_patches"),
    "zero_iterations": (sub("cache = false", "cache = false\nmax_iterations = 0"), 1,
                        "solver.max_iterations"),
    "tiny_patch_size": (sub("cache = false", "cache = false\npatch_size = 1e-9", INDIRECT), 1,
                        "solver: patches of 1e-09 m make about"),
    "huge_operator": (sub("cache = false", "cache = false\ntarget_patches = 10000000", INDIRECT),
                      1, "solver: the transport operator of"),
    "group_scale_zero": (BASE + "[groups.g]\nscale = 0\n", 1, "groups.g.scale"),
    "maintenance_zero": (sub('network = "a"', 'network = "a"\nmaintenance_factor = 0'), 1,
                         "luminaires[0].maintenance_factor"),
    # names that do not resolve, or resolve twice
    "unknown_network": (sub('network = "a"', 'network = "b"'), 1,
                        "luminaires[0].network: unknown network 'b'"),
    "unknown_spectrum": (sub('network = "a"', 'network = "a"\nspectrum = "NOPE"'), 1,
                         "luminaires[0].spectrum"),
    "duplicate_luminaire": (BASE + '[[luminaires]]\nname = "A1"\nphotometry = "iso"\n'
                            'position = [2, 1, 2]\nnetwork = "a"\n', 1,
                            "luminaires[1].name: duplicate"),
    "duplicate_grid": (BASE + '[[grids]]\nname = "floor"\nkind = "plane"\norigin = [0, 0, 1]\n'
                       'u = [1, 0, 0]\nv = [0, 1, 0]\nnu = 2\nnv = 2\n', 1,
                       "grids[1].name: duplicate"),
    "group_cycle": (BASE + "[groups.g1]\nparent = 'g2'\n[groups.g2]\nparent = 'g1'\n", 1,
                    "groups.g1.parent"),
    # an optimiser with nothing to do
    "pinned_dimmers": (target() + "[optimise]\ndimmer_min = 1\n", 1, "optimise.dimmer_min"),
    "pinned_aims": (target() + '[optimise]\nvariables = ["aims"]\ntilt_range_deg = [0, 0]\n'
                    'pan_range_deg = [0, 0]\n', 1, "optimise.variables: nothing can change"),
    "aims_without_photometry": (target(text=sub('photometry = "iso"\nposition = [1, 1.5, 2.5]',
                                                AREA)) + '[optimise]\nvariables = ["dimmers", '
                                '"aims"]\n', 1, "optimise.variables: 'aims'"),
}


@pytest.fixture
def probe_dir(tmp_path):
    for name, text in FILES.items():
        (tmp_path / name).write_text(text)
    (tmp_path / "adir").mkdir()
    return tmp_path


def _line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") <= 1, err
    return err.strip()


@pytest.mark.parametrize("name", list(CHECK))
def test_check_probe(name, probe_dir, capsys):
    text, status, words = CHECK[name]
    path = probe_dir / f"{name}.toml"
    path.write_text(textwrap.dedent(text))
    assert main(["check", str(path)]) == status
    line = _line(capsys)
    assert line.startswith("lumijax: error: ") and words in line, line


@pytest.mark.parametrize("where,words", [
    (None, "config file not found"), ("adir", "cannot read config"),
    ("binary.toml", "cannot read config"),
])
def test_a_config_that_is_not_a_text_file(where, words, probe_dir, capsys):
    (probe_dir / "binary.toml").write_bytes(b"\xff\xfe\x00bad")
    path = probe_dir / (where or "nowhere.toml")
    assert main(["check", str(path)]) == 1
    assert words in _line(capsys)


def _run(text, probe_dir, name):
    path = probe_dir / f"{name}.toml"
    path.write_text(text)
    out = probe_dir / f"out_{name}"
    assert main(["run", str(path), "--out", str(out), "--no-report", "--no-images"]) == 0
    return json.loads((out / "results.json").read_text())  # strict JSON: no NaN, no Infinity


def test_a_grid_outside_the_closed_room_is_dark_and_the_fit_says_so(probe_dir):
    # the lamp is inside a closed box: nothing reaches a grid above its roof, at any dimmer
    text = target(text=sub("origin = [0, 0, 0.01]", "origin = [0, 0, 10]")) + "[optimise]\n"
    res = _run(text, probe_dir, "outside")
    g = res["grids"]["floor"]
    assert g["illuminance_lux"] == [0.0] * 48 and g["stats"]["u0"] == 0.0
    assert any("100" in line for line in res["optimisation"]["unmet"])


def test_a_study_without_grids_or_with_an_empty_network_runs(probe_dir):
    res = _run(BASE.split("[[grids]]")[0] + "[networks.empty]\n", probe_dir, "nogrids")
    assert res["grids"] == {} and res["networks"]["empty"]["luminaires"] == []
    res = _run(BASE + "[networks.empty]\n", probe_dir, "empty")
    lux = np.array(res["grids"]["floor"]["by_network_lux"]["empty"])
    assert (lux == 0).all()
