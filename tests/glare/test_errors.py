"""Bad observers get one precise error naming the key (or a named warning), never a traceback
or a NaN: zero lines of sight, empty fans, unknown groups and grids, an eye inside a solid or
a luminaire."""

from __future__ import annotations

import math

import pytest
from _glare import rect, scene_of, write_with_opening
from helpers import box, lamp, material, observer, photometry, point_grid, study_text, table

from lumijax import ConfigError, GeometryError
from lumijax.config import parse_config
from lumijax.glare import NearSourceWarning, Observer, build_glare_model, build_observers
from lumijax.photometry import isotropic
from lumijax.scene import build_scene

# a solid 1 × 1 × 2 m box at x 2..3, y 1..2; a group 10 m along x; one grid point
BASE = study_text(material("wall", 0.5), table("groups.g", translate=[10, 0, 0]),
                  box([2, 1, 0], [3, 2, 2], normals=None),
                  point_grid("floor", [[0, 0, 0]]))
EYE = [0, 0, 1.5]  # m, outside the box


@pytest.mark.parametrize(("body", "key", "words"), [
    ('direction = [0, 0, 0]', "observers[0]", "zero vector"),
    ('look_at = [0, 0, 1.5]', "observers[0]", "own position"),
    ('direction = [1, 0, 0]\nlook_at = [1, 0, 0]', "observers[0]", "exactly one"),
    ('direction = [1, 0, 0]\nfan = { azimuths_deg = [] }', "observers[0].fan", "at least one"),
    ('direction = [1, 0, 0]\nfan = { step_deg = 15, azimuths_deg = [0] }', "observers[0].fan",
     "exactly one"),
    ('direction = [0, 0, -1]\nfan = { step_deg = 15 }', "observers[0]", "vertical"),
    ('direction = [1, 0, 0]\ngroup = "nope"', "observers[0].group", "unknown group"),
    ('direction = [1, 0, 0]\nroad_grid = "road"', "observers[0].road_grid", "unknown grid"),
    ('direction = [1, 0, 0]\nroad_grid = "floor"\nroad_luminance_cdm2 = 1', "observers[0]",
     "not both"),
])
def test_bad_observer_tables_name_the_key(body, key, words):
    text = BASE + observer("o", EYE) + body + "\n"
    with pytest.raises(ConfigError) as err:
        parse_config(text, source="study.toml")
    assert err.value.key == key and words in err.value.message
    assert err.value.line is not None  # the CLI prints study.toml:LINE: key: message


def test_duplicate_observer_names_are_refused():
    one = observer("o", EYE, direction=[1, 0, 0])
    with pytest.raises(ConfigError, match="duplicate observer name 'o'") as err:
        parse_config(BASE + one + one)
    assert err.value.key == "observers[1].name"


def test_group_frame_places_the_eye_and_turns_the_fan():
    cfg = parse_config(BASE + observer("o", EYE, direction=[1, 0, 0], group="g",
                                       fan={"step_deg": 90}))
    (o,) = build_observers(cfg)
    assert o.eye.tolist() == [10.0, 0.0, 1.5]
    assert o.directions.round(12).tolist() == [[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]]


def test_an_eye_inside_a_solid_is_refused():
    cfg = parse_config(BASE + observer("ok", EYE, direction=[1, 0, 0])
                       + observer("inside", [2.5, 1.5, 1], direction=[1, 0, 0]))
    with pytest.raises(GeometryError, match="'inside'.*inside the closed solid") as err:
        build_observers(cfg, build_scene(cfg))
    assert err.value.key == "observers[1].position"


def test_an_eye_inside_a_luminaire_is_refused_and_near_one_warned(tmp_path):
    ies = write_with_opening(tmp_path / "bar.ies", isotropic(4 * math.pi * 100), rect(1.2, 0.2))
    scene = scene_of(photometry("bar", file=ies), lamp("bar", [0, 0, 3], "a", "bar"))
    with pytest.raises(GeometryError, match="inside its luminous extent") as err:
        build_glare_model(scene, [Observer.looking("o", [0.2, 0, 2.9], [1, 0, 0],
                                                   key="observers[0]")])
    assert err.value.key == "observers[0].position"
    with pytest.warns(NearSourceWarning, match="closer than its size"):
        build_glare_model(scene, [Observer.looking("o", [0.9, 0, 3], [1, 0, 0])])
