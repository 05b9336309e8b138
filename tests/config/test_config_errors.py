"""Bad configs get one precise error naming the file, line and key path."""

from __future__ import annotations

import pytest
from helpers import box, lamp, material, network, photometry, plane_grid, study_text

from lumijax import ConfigError, load_study
from lumijax.config import load_config

BASE = study_text(
    material("wall", 0.5), photometry("iso", "isotropic", 1000), network("main", 0.5),
    box([0, 0, 0], [4, 5, 3]), lamp("L0", [1, 1, 2.9], "main"),
    lamp("L1", [2, 2.5, 2.9], "main", aim={"tilt": 10, "pan": 0}),
    plane_grid("wp", [0, 0, 0.8], [4, 0, 0], [0, 5, 0], nu=8, nv=10))


def test_base_config_is_valid(write_study):
    cfg = load_config(write_study(BASE))
    assert cfg.luminaires[1].aim.tilt == 10
    assert cfg.networks["main"].dimmer == 0.5


@pytest.mark.parametrize(
    "old,new,key,line,words",
    [
        ("tilt = 10", 'tilt = "ten"', "luminaires[1].aim.tilt", 25, "expected a number"),
        ("nv = 10", "nv = 10\nnvv = 3", "grids[0].nvv", 34, "unknown key"),
        ('kind = "box"', 'kind = "cube"', "geometry[0]", 9, "unknown kind 'cube'"),
        ('material = "wall"', 'material = "wal"', "geometry[0].material", 14, "unknown material"),
        ("reflectance = 0.5", "reflectance = 1.0", "materials.wall", 2, "must be in [0, 1)"),
        ("position = [1, 1, 2.9]", "position = [1, 1]", "luminaires[0].position", 18,
         "list of 3 numbers"),
        ('network = "main"\naim', 'network = "mian"\naim', "luminaires[1].network", 24,
         "unknown network 'mian'"),
        ('kind = "isotropic"\nflux_lm = 1000', 'file = "missing.ies"', "photometry.iso.file", 5,
         "file not found"),
        ("dimmer = 0.5", "dimmer = 1.5", "networks.main.dimmer", 8, "less than or equal to 1"),
        ("nu = 8", "spacing = 0.5", "grids[0]", 26, "not both"),
        ('name = "L1"', 'name = "L0"', "luminaires[1].name", 21, "duplicate luminaire name"),
        ("min = [0, 0, 0]", "min = [0, 0, nan]", "geometry[0].min[2]", 11, "finite"),
        ("max = [4, 5, 3]", "max = [4, 5, -3]", "geometry[0]", 9, "must exceed"),
        ('photometry = "iso"\nposition = [1', 'photometry = "spot"\nposition = [1',
         "luminaires[0].photometry", 17, "unknown photometry 'spot'"),
    ],
)
def test_error_names_key_line_and_expectation(write_study, old, new, key, line, words):
    assert old in BASE
    path = write_study(BASE.replace(old, new, 1))
    with pytest.raises(ConfigError) as info:
        load_config(path)
    e = info.value
    assert e.key == key
    assert e.file == str(path)
    assert e.line == line, str(e)
    assert words in e.message
    assert str(e).startswith(f"{path}:{line}: {key}: ")


def test_toml_syntax_error_gives_line(write_study):
    path = write_study(BASE.replace("[[grids]]", "[[grids]\n"))
    with pytest.raises(ConfigError, match=r"invalid TOML") as info:
        load_config(path)
    assert info.value.line == 26


def test_missing_config_file(tmp_path):
    with pytest.raises(ConfigError, match="config file not found"):
        load_config(tmp_path / "nope.toml")


def test_group_cycle_and_unknown_parent(write_study):
    text = BASE + '[groups.a]\nparent = "b"\n[groups.b]\nparent = "a"\n'
    with pytest.raises(ConfigError, match="cycle") as info:
        load_config(write_study(text))
    assert info.value.key in ("groups.a.parent", "groups.b.parent")
    with pytest.raises(ConfigError, match="unknown group 'c'"):
        load_config(write_study(BASE + '[groups.a]\nparent = "c"\n'))


def test_relative_paths_resolve_against_the_config_folder(tmp_path, shared_photometry):
    sub = tmp_path / "project"
    (sub / "phot").mkdir(parents=True)
    ies = shared_photometry / "lx_Testlamp_Isym1_007cfb11e343e2f42e3b476be4ab684e.ies"
    (sub / "phot" / "down.ies").write_bytes(ies.read_bytes())
    text = BASE.replace('kind = "isotropic"\nflux_lm = 1000', 'file = "phot/down.ies"')
    (sub / "study.toml").write_text(text)
    cfg = load_config(sub / "study.toml")
    assert cfg.photometry["iso"].file == (sub / "phot" / "down.ies").resolve()


@pytest.mark.parametrize(
    "old,new,key,words",
    [
        ('[[luminaires]]\nname = "L0"', '[[luminaires]]\nspectrum = "NOT-A-LAMP"\nname = "L0"',
         "luminaires[0].spectrum", "NOT-A-LAMP"),
        ("reflectance = 0.5", 'reflectance = "not a colour"', "materials.wall", "not a colour"),
        ("reflectance = 0.5", "srgb = [1.0, 1.0, 1.0]", "materials.wall", "< 1"),
    ],
)
def test_scene_level_errors_name_the_config_key(write_study, old, new, key, words):
    path = write_study(BASE.replace(old, new, 1))
    with pytest.raises(ConfigError) as info:
        load_study(path)
    assert info.value.key == key
    assert words in str(info.value)


@pytest.mark.parametrize(
    "old,new,key",
    [("flux_lm = 1000", "flux_lm = inf", "photometry.iso.flux_lm"),
     ('network = "main"\naim', 'network = "main"\nmultiplier = inf\naim', "luminaires[1].multiplier"),
     ("nu = 8\nnv = 10", "spacing = inf", "grids[0].spacing")],
)
def test_infinite_values_are_refused(write_study, old, new, key):
    with pytest.raises(ConfigError, match="finite") as info:
        load_config(write_study(BASE.replace(old, new, 1)))
    assert info.value.key == key


def test_source_is_not_a_config_key(write_study):
    with pytest.raises(ConfigError, match="unknown key"):
        load_config(write_study('source = "elsewhere.toml"\n' + BASE))


def test_unknown_luminaire_kind_lists_the_valid_ones(write_study):
    with pytest.raises(ConfigError, match="'photometric', 'area'"):
        load_config(write_study(BASE.replace('name = "L0"', 'name = "L0"\nkind = "spot"', 1)))


def test_a_model_level_error_names_its_own_tables_line(write_study):
    # ρ_d + ρ_s + τ > 1 is checked on the whole [materials.glossy] table (a model-level error):
    # its line is that table's header, not the first [materials.*] one above it.
    text = BASE + material("glossy", 0.5, specular=0.6)
    with pytest.raises(ConfigError) as info:
        load_config(write_study(text))
    assert info.value.key == "materials.glossy"
    assert info.value.line == text.splitlines().index("[materials.glossy]") + 1
