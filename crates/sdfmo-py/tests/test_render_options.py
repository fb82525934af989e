"""``sdfmo.RenderOptions`` (issue 36): the camera, mode and shading of a render declared once,
for ``Mesh.render`` and ``Octree.render`` as ``options=``; the same keywords given to
``render`` itself make the same object, so both ways give the same image bytes."""


import numpy as np
import pytest

import sdfmo
from sdfmo import RenderOptions

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
MESH = sdfmo.Mesh(V, F)
OCTREE = MESH.build(5)

# Keyword sets that each change the image (one per option, and a combination).
KEYWORDS = [
    {},
    {"mode": "mask"},
    {"mode": "depth", "view": 2},
    {"mode": "normal", "fov": 35.0},
    {"view": 1, "shadows": True, "ao": 4},
    {"eye": (2.0, 1.5, 2.5), "target": (0.25, 0.25, 0.25)},
    {"eye": [0.0, 0.5, 2.8], "frame": "normalized"},
]


def test_defaults_are_the_renderers_and_show_in_the_repr():
    o = RenderOptions()
    assert (o.mode, o.view, o.eye, o.target, o.fov, o.frame, o.shadows, o.ao) == (
        "lambert", 0, None, None, None, "model", False, 0)
    assert repr(o) == ("RenderOptions(mode='lambert', view=0, eye=None, target=None, fov=None, "
                       "frame='model', shadows=False, ao=0)")


@pytest.mark.parametrize("kw", KEYWORDS)
def test_the_repr_evaluates_to_an_equal_object(kw):
    o = RenderOptions(**kw)
    assert eval(repr(o), {"RenderOptions": RenderOptions}) == o


def test_equality_is_field_by_field():
    assert RenderOptions(mode="mask", view=1) == RenderOptions(view=1, mode="mask")
    assert RenderOptions(eye=[1, 2, 3]) == RenderOptions(eye=(1.0, 2.0, 3.0))
    assert RenderOptions(mode="mask") != RenderOptions()
    assert RenderOptions(eye=(1, 2, 3)) != RenderOptions(eye=(1, 2, 3), frame="normalized")
    assert RenderOptions() != "RenderOptions()"
    with pytest.raises(AttributeError):
        RenderOptions().mode = "mask"  # type: ignore[misc]


@pytest.mark.parametrize("kw", KEYWORDS)
@pytest.mark.parametrize("source", ["mesh", "octree"])
def test_options_and_keywords_give_the_same_image_bytes(source, kw):
    render = {"mesh": MESH, "octree": OCTREE}[source].render
    by_keywords = render(24, 16, threads=2, **kw)
    by_options = render(24, 16, options=RenderOptions(**kw), threads=2)
    assert by_keywords.shape == (16, 24, 3)
    assert by_keywords.tobytes() == by_options.tobytes()


def test_the_options_reach_the_image():
    # Each keyword set draws another image: none of the options is dropped on the way.
    images = {OCTREE.render(24, options=RenderOptions(**kw), threads=1).tobytes() for kw in KEYWORDS}
    assert len(images) == len(KEYWORDS)


def test_one_options_object_serves_levels_of_detail():
    mask = RenderOptions(mode="mask")
    assert OCTREE.render(16, options=mask, lod=OCTREE.depth).tobytes() == \
        OCTREE.render(16, mode="mask", lod=OCTREE.depth).tobytes()


@pytest.mark.parametrize("kw, field", [
    ({"mode": "phong"}, "mode"),
    ({"view": 4}, "view"),
    ({"view": -1}, "view"),
    ({"eye": [1, 2]}, "eye must be 3 numbers"),
    ({"target": [1, 2, 3, 4]}, "target must be 3 numbers"),
    ({"fov": 180.0}, "fov"),
    ({"fov": 0.0}, "fov"),
    ({"fov": float("nan")}, "fov"),
    ({"frame": "world"}, "frame must be"),
    ({"ao": -1}, "ao must be in 0..=1024"),
    ({"ao": 1025}, "ao must be in 0..=1024"),
    ({"mode": "mask", "shadows": True}, "shadows and ao apply to mode=\"lambert\" only"),
    ({"mode": "depth", "ao": 2}, "shadows and ao apply to mode=\"lambert\" only"),
])
def test_bad_values_raise_value_error_naming_the_field(kw, field):
    with pytest.raises(ValueError, match=field):
        RenderOptions(**kw)
    # The same through render's keywords: the same check.
    with pytest.raises(ValueError, match=field):
        MESH.render(8, **kw)


@pytest.mark.parametrize("kw, field", [
    ({"mode": 1}, "mode"),
    ({"view": "front"}, "view"),
    ({"eye": "abc"}, "eye"),
    ({"fov": "wide"}, "fov"),
    ({"shadows": "yes"}, "shadows"),
    ({"ao": 2.5}, "ao"),
    ({"colour": "red"}, "unexpected keyword argument 'colour'"),
])
def test_wrong_types_and_names_raise_type_error(kw, field):
    with pytest.raises(TypeError) as e:
        RenderOptions(**kw)
    # PyO3 names the argument in the message or (Python >= 3.11) in a note under it.
    assert field in str(e.value) + "".join(getattr(e.value, "__notes__", [])), e.value
    with pytest.raises(TypeError):
        OCTREE.render(8, **kw)


def test_options_must_be_a_render_options_and_not_mixed_with_keywords():
    with pytest.raises(TypeError, match="options"):
        MESH.render(8, options={"mode": "mask"})
    with pytest.raises(TypeError, match=r"options= or its keywords \(\['mode'\]\), not both"):
        OCTREE.render(8, options=RenderOptions(), mode="mask")
    with pytest.raises(TypeError):
        RenderOptions("mask")  # keyword-only


def test_the_camera_checks_that_need_the_source_stay_in_render():
    # eye == target in model units is only known against the mesh's frame.
    same = RenderOptions(eye=(0, 0, 0), target=(0, 0, 0))
    with pytest.raises(ValueError, match="eye and target are the same point"):
        MESH.render(8, options=same)
    with pytest.raises(ValueError, match="width must be at least 1"):
        MESH.render(0, options=RenderOptions())


def test_none_is_the_renderers_default():
    assert RenderOptions(mode=None, shadows=None, ao=None) == RenderOptions()
    assert RenderOptions(mode="lambert", shadows=False, ao=0) == RenderOptions()
