"""The resolved scene (``Scene.to_yaml``, what ``dump_resolved`` writes as a run folder's config.yaml) loads
back to the same scene, in 3D too: a vector left at its default (``fluid.body_force``,
``solid.initial_velocity``) is resolved with the scene's dimension, so the file says [0.0, 0.0, 0.0] in 3D,
which the 3D scene accepts when the file is read again (a restart, a study's rerun, a copied run folder).
Validation only: no mesh is built."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from cosserat_fsi.config import load_scene
from cosserat_fsi.config.scene import condition_lines, dump_resolved

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data" / "user_scene"
CONFIGS = sorted((REPO / "configs").glob("*.yaml"))
FILE_SCENES = {  # a 3D file scene: its .geo and the scene's text
    "box_channel": ("box_channel.geo", """\
geometry: {name: file, path: box_channel.geo}
fluid: {rho: 1.0, mu: 1.0}
micropolar: {mu_r: 0.5, lambda1: 0.1}
boundaries:
  inlet: {type: velocity, value: ['y*(0.4 - y)/0.04', 0, 0], micro_rotation: zero}
  outlet: {type: do_nothing}
  plates: {type: no_slip}
  sides: {type: slip}
observables: {points: {C: [0.5, 0.2, 0.2]}, lines: {L: {from: [0.5, 0, 0.2], to: [0.5, 0.4, 0.2], points: 5}},
              flow_rates: [outlet]}
time: {scheme: steady}
"""),
    "block_box_solid": ("block_box.geo", """\
geometry: {name: file, path: block_box.geo}
fluid: {rho: 1.0, mu: 1.0}
solid: {rho: 1.0, mu_s: 100.0}
boundaries: {inlet: {type: velocity, value: ['1', 0, 0]}, outlet: {type: do_nothing}, walls: {type: no_slip}}
observables: {solid_points: {tip: [0.6, 0.2, 0.2]}}
time: {scheme: characteristics1, dt: 0.1, t_end: 0.2}
"""),
    "box_channel_by_name": ("box_channel.geo", """\
geometry: {name: file, path: box_channel.geo}
fluid: {rho: 1.0, mu: 1.0}
inflow: {u_mean: 1.0}
time: {scheme: steady}
"""),
}


def _round_trip(scene, tmp_path: Path):
    """The scene as dump_resolved writes it (with the conditions' comment block), loaded again."""
    text = dump_resolved(scene, condition_lines(scene, scene.conditions(["inlet", "outlet", "walls"]), True)
                         if scene.boundaries is None and scene.geometry.name != "file" else None)
    path = tmp_path / "config.yaml"
    path.write_text(text)
    return load_scene(path), text


@pytest.mark.parametrize("config", CONFIGS, ids=[c.stem for c in CONFIGS])
def test_every_shipped_config_loads_back(config, tmp_path):
    scene = load_scene(config)
    again, text = _round_trip(scene, tmp_path)
    assert again == scene and again.model_dump() == scene.model_dump()
    if scene.fluid is not None:
        assert yaml.safe_load(text)["fluid"]["body_force"] == [0.0] * scene.geometry.DIM


def test_the_shipped_configs_include_3d_ones():
    assert sum(load_scene(c).geometry.DIM == 3 for c in CONFIGS) >= 3


@pytest.mark.parametrize("geo, text", FILE_SCENES.values(), ids=FILE_SCENES)
def test_3d_file_scene_loads_back(geo, text, tmp_path):
    (tmp_path / geo).write_text((DATA / geo).read_text())
    (tmp_path / "scene.yaml").write_text(text)
    scene = load_scene(tmp_path / "scene.yaml")
    assert scene.geometry.DIM == 3
    folder = tmp_path / "run"  # the run folder: another folder than the scene's (the path is absolute)
    folder.mkdir()
    again, dumped = _round_trip(scene, folder)
    assert again == scene and again.model_dump() == scene.model_dump()
    data = yaml.safe_load(dumped)
    assert data["fluid"]["body_force"] == [0.0, 0.0, 0.0]
    if scene.solid is not None:
        assert data["solid"]["initial_velocity"] == [0.0, 0.0, 0.0]
    assert Path(data["geometry"]["path"]).is_absolute()
    twice, _ = _round_trip(again, folder)  # a restart of a restart
    assert twice == scene


@pytest.mark.parametrize("sections, key, expected", [
    ({"geometry": {"name": "cube"}}, "body_force", [0.0, 0.0, 0.0]),
    ({"geometry": {"name": "square"}}, "body_force", [0.0, 0.0]),
    ({"geometry": {"name": "cube"}, "fluid": {"rho": 1.0, "mu": 1.0, "body_force": [0.0, 1.0, 2.0]}}, "body_force",
     [0.0, 1.0, 2.0]),
], ids=["3d_default", "2d_default", "3d_given"])
def test_default_vectors_have_the_scene_dimension(sections, key, expected):
    from cosserat_fsi.config import validate_scene

    scene = validate_scene({"fluid": {"rho": 1.0, "mu": 1.0}, "time": {"scheme": "steady"}, **sections})
    assert getattr(scene.fluid, key) == expected
