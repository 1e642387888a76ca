"""Terrain: parsing, the surface MuJoCo builds, contact parameters, robots resting on it."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from matplotlib import image

import tensim
from tensim.cli import main
from tensim.models import preset
from tensim.sim import Simulation
from tensim.structure import Node, PointMass, Rod, Structure
from tensim.terrain import (
    Blocks,
    Flat,
    HeightField,
    Hills,
    Rough,
    Slope,
    Stairs,
    TerrainError,
    Wall,
    format_terrain,
    parse_terrain,
    place_on_terrain,
)

# every kind, with its feature moved under the robot (built around the origin) so that the
# robot is lifted onto it and rests on it, not beside it
UNDER_ROBOT = {
    "flat": "flat",
    "slope": "slope:angle=8,start=-1.0,length=3",
    "hills": "hills:height=0.05,wavelength=1.5,size=2",
    "rough": "rough:roughness=0.01,correlation=0.1,seed=4,size=1.5,resolution=0.02",
    "stairs": "stairs:rise=0.04,run=0.25,steps=4,start=-0.6",
    "blocks": "blocks:count=30,size=0.25,height=0.04,start=-0.8,length=1.6,width=1.6,seed=2",
    "wall": "wall:height=0.08,distance=-0.4,thickness=0.8,width=1.5",
}


def _world(terrain: object, **options: float) -> tensim.WorldOptions:
    return tensim.WorldOptions(terrain=terrain, **options)  # type: ignore[arg-type]


def _ray_heights(compiled: tensim.CompiledModel, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Surface heights found by MuJoCo's own ray caster, straight down onto world geoms."""
    m = compiled.model
    m.geom_group[m.geom_bodyid != 0] = 1  # robot geoms out of the rays' way
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    world_only = np.zeros(mujoco.mjNGROUP, dtype=np.uint8)
    world_only[0] = 1
    heights, geom = [], np.zeros(1, dtype=np.int32)
    for a, b in zip(x, y, strict=True):
        start = np.array([a, b, 10.0])
        dist = mujoco.mj_ray(m, d, start, np.array([0.0, 0.0, -1.0]), world_only, 1, -1, geom)
        assert m.geom_bodyid[geom[0]] == 0, "the ray must hit the terrain, not the robot"
        heights.append(10.0 - dist)
    return np.array(heights)


def _image_file(tmp_path):
    # a 3 x 4 grey ramp with one white pixel in the top-right corner (seen from above: +x, +y)
    grey = np.array([[0.0, 0.2, 0.4, 1.0], [0.0, 0.2, 0.4, 0.6], [0.0, 0.0, 0.0, 0.0]])
    path = tmp_path / "field.png"
    image.imsave(path, grey, cmap="gray", vmin=0.0, vmax=1.0)
    return path


# -- parsing --------------------------------------------------------------------------------


def test_parse_reads_kind_fields_and_types():
    t = parse_terrain("hills:height=0.2, wavelength=3,friction=0.6")
    assert t == Hills(height=0.2, wavelength=3.0, friction=0.6)
    assert parse_terrain("stairs:steps=3") == Stairs(steps=3)
    assert parse_terrain(" FLAT ") == Flat()


@pytest.mark.parametrize("terrain", [
    Flat(friction=0.3, restitution=0.5), Slope(angle=-12.5, start=1.0),
    Hills(height=0.07), Rough(roughness=0.03, seed=11), Stairs(rise=0.1, steps=2),
    Blocks(count=5, seed=3), Wall(height=0.2, distance=1.5),
    HeightField(file="ground.png", length=4.0, height=0.3)])
def test_format_then_parse_gives_the_same_terrain(terrain):
    assert parse_terrain(format_terrain(terrain)) == terrain


@pytest.mark.parametrize(("text", "message"), [
    ("mountains", "unknown kind 'mountains'; expected one of flat, slope"),
    ("hills:hieght=0.1", "unknown key 'hieght' for hills; expected one of"),
    ("wall:height=high", "height expects a number, got 'high'"),
    ("stairs:steps=2.5", "steps expects an integer, got '2.5'"),
    ("rough:seed", "expected key=value, got 'seed'"),
    ("wall:height=0.1,height=0.2", "'height' given twice"),
    ("wall:height=-0.1", "height must be > 0 [m], got -0.1"),
    ("slope:angle=0", "angle must be a nonzero angle"),
    ("flat:restitution=0.5", "give friction=... as well"),
    ("flat:friction=-1", "friction must be a coefficient >= 0"),
    ("hills:resolution=0.0001", "samples"),
])
def test_parse_errors_name_the_string_field_and_expectation(text, message):
    with pytest.raises(TerrainError, match="terrain") as err:
        parse_terrain(text)
    assert message in str(err.value)
    assert isinstance(err.value, ValueError)  # the CLI reports ValueErrors with exit status 2


def test_records_check_their_fields_when_built_from_python_too():
    with pytest.raises(TerrainError, match=r"steps must be an integer >= 1, got 2\.5"):
        Stairs(steps=2.5)  # type: ignore[arg-type]
    with pytest.raises(TerrainError, match="roughness must be > 0"):
        Rough(roughness=0.0)
    with pytest.raises(TerrainError, match="file must be the path"):
        HeightField()


def test_bad_terrain_on_the_command_line_exits_2_with_the_message(tmp_path, capsys):
    status = main(["--quiet", "simulate", "prism3", "--terrain", "hills:hieght=1",
                   "--out", str(tmp_path)])
    assert status == 2
    assert "unknown key 'hieght' for hills" in capsys.readouterr().err


def test_terrain_option_on_simulate_runs(tmp_path):
    out = tmp_path / "run"
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.5", "--terrain",
                 "wall:height=0.05,friction=0.5", "--out", str(out)]) == 0
    assert (out / "summary.json").exists()


# -- the surface --------------------------------------------------------------------------


@pytest.mark.parametrize("kind", [*UNDER_ROBOT, "slope_down", "image", "array"])
def test_surface_height_is_what_mujoco_built(kind, tmp_path):
    # the height function (used to place robots and in tests) against MuJoCo's ray caster
    if kind == "slope_down":
        terrain = Slope(angle=-20, start=0.5, length=2.0)
    elif kind == "image":
        terrain = HeightField(file=str(_image_file(tmp_path)), length=3.0, height=0.2)
    elif kind == "array":
        np.save(tmp_path / "field.npy", np.random.default_rng(1).uniform(-0.05, 0.1, (7, 9)))
        terrain = HeightField(file=str(tmp_path / "field.npy"), length=2.0, width=1.5)
    else:
        terrain = parse_terrain(UNDER_ROBOT[kind])
    compiled = tensim.compile_structure(preset("prism3").build(), _world(terrain))
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-1.4, 1.4, 300), rng.uniform(-0.7, 0.7, 300)
    # float32 storage of MuJoCo's height-field samples: ~1e-7 of the height range
    assert np.allclose(_ray_heights(compiled, x, y), terrain.geometry().height(x, y), atol=1e-6)


def test_shapes_have_their_closed_form_heights():
    slope = Slope(angle=20.0, start=0.5, length=2.0).geometry()
    rise = 2.0 * math.sin(math.radians(20.0))
    assert slope.height(0.0, 3.0) == pytest.approx(0.0, abs=1e-12)
    assert slope.height(1.5, -2.0) == pytest.approx(math.tan(math.radians(20.0)))
    assert slope.height(10.0, 0.0) == pytest.approx(rise)
    stairs = Stairs(rise=0.05, run=0.3, steps=4, start=0.5).geometry()
    assert stairs.height(0.4, 0.0) == 0.0
    assert stairs.height(0.5 + 2.5 * 0.3, 0.0) == pytest.approx(3 * 0.05)
    assert stairs.height(3.0, 0.0) == pytest.approx(4 * 0.05)  # the landing
    wall = Wall(height=0.12, distance=0.5, thickness=0.1).geometry()
    assert [float(wall.height(x, 0.0)) for x in (0.45, 0.55, 0.65)] == pytest.approx(
        [0.0, 0.12, 0.0])
    # h sin(2πx/λ) cos(2πy/λ): crest at (λ/4, 0), trough at (λ/4, λ/2), zero on x = 0
    hills = Hills(height=0.1, wavelength=2.0, size=3.0, resolution=0.05).geometry()
    assert hills.height(0.5, 0.0) == pytest.approx(0.1, abs=1e-9)
    assert hills.height(0.5, 1.0) == pytest.approx(-0.1, abs=1e-9)
    assert hills.height(0.0, 0.3) == pytest.approx(0.0, abs=1e-12)


def test_rough_ground_has_its_rms_height_and_depends_only_on_the_seed():
    a = Rough(roughness=0.03, correlation=0.1, seed=7, size=2.0).geometry().grid
    b = Rough(roughness=0.03, correlation=0.1, seed=7, size=2.0).geometry().grid
    c = Rough(roughness=0.03, correlation=0.1, seed=8, size=2.0).geometry().grid
    assert np.array_equal(a.heights, b.heights)
    assert not np.allclose(a.heights, c.heights)
    assert np.sqrt(np.mean(a.heights**2)) == pytest.approx(0.03, rel=1e-9)
    # correlated over ~0.1 m: neighbours 2 cm apart differ by far less than the RMS height
    step = np.diff(a.heights, axis=1)
    assert np.sqrt(np.mean(step**2)) < 0.3 * 0.03


def test_image_height_field_top_row_is_at_plus_y(tmp_path):
    field = HeightField(file=str(_image_file(tmp_path)), length=3.0, height=0.2).geometry()
    # columns at x = -1.5, -0.5, 0.5, 1.5; rows (top of the picture first) at y = +1, 0, -1
    assert field.height(1.5, 1.0) == pytest.approx(0.2, abs=2e-3)  # white: 8-bit grey levels
    assert field.height(0.5, 0.0) == pytest.approx(0.4 * 0.2, abs=2e-3)
    assert field.height(1.5, -1.0) == pytest.approx(0.0, abs=2e-3)


@pytest.mark.parametrize(("name", "content", "message"), [
    ("missing.npy", None, "does not exist"),
    ("field.dat", "1 2\n3 4\n", "unknown type '.dat'"),
    ("line.csv", "1,2,3\n", "expected a 2-D grid of at least 2 x 2"),
    ("holes.csv", "1,2\nnan,4\n", "heights must be finite"),
    ("words.csv", "a,b\nc,d\n", "cannot be read"),
])
def test_bad_height_field_files_are_named(tmp_path, name, content, message):
    path = tmp_path / name
    if content is not None:
        path.write_text(content)
    with pytest.raises(TerrainError, match=message) as err:
        HeightField(file=str(path)).geometry()
    assert name in str(err.value)


# -- placing a robot ------------------------------------------------------------------------


def test_robot_is_lifted_clear_of_the_ground_under_it():
    structure = preset("tetraspine3").build()
    terrain = Hills(height=0.08, wavelength=0.7, size=2.0, resolution=0.02)
    placed = place_on_terrain(structure, terrain)
    geometry = terrain.geometry()
    for before, after in zip(structure.nodes, placed.nodes, strict=True):
        under = float(geometry.height(after.position[0], after.position[1]))
        assert after.position[:2] == before.position[:2]
        # every node keeps at least its build height above the ground beneath it
        assert after.position[2] - under >= before.position[2] - 1e-12
    assert place_on_terrain(structure, Flat()) is structure
    assert place_on_terrain(structure, Wall()) is structure  # the wall is ahead of it


def test_a_plane_lifts_by_its_height_without_sampling_it():
    from tensim.terrain._geometry import Geometry
    from tensim.terrain._place import footprint_height

    class Plane:  # a terrain of a plane alone (or nothing): its one height, as sampled
        def __init__(self, plane: float | None):
            self.plane = plane

        def geometry(self) -> Geometry:
            return Geometry(plane=self.plane)

    structure = preset("tetraspine3").build()
    for plane, lift in ((0.25, 0.25), (-0.1, -0.1), (0.0, 0.0), (None, 0.0)):
        assert footprint_height(structure, Plane(plane)) == lift  # type: ignore[arg-type]
        sampled = Geometry(plane=plane).height(np.linspace(-1, 1, 5), np.zeros(5)).max()
        assert lift == (sampled if np.isfinite(sampled) else 0.0)
    placed = place_on_terrain(structure, Plane(0.25))  # type: ignore[arg-type]
    assert [n.position[2] for n in placed.nodes] == [n.position[2] + 0.25
                                                     for n in structure.nodes]


def _node_clearance(sim: Simulation, geometry: object, radius: dict[str, float]) -> float:
    """Smallest gap between a node's sphere (or rod end) and the terrain beneath it [m]."""
    gaps = []
    for node, local in sim.index.node_local.items():
        body = sim.index.node_body[node]
        p = sim.data.xpos[body] + sim.data.xmat[body].reshape(3, 3) @ local
        gaps.append(p[2] - radius[node] - float(geometry.height(p[0], p[1])))  # type: ignore[attr-defined]
    return min(gaps)


@pytest.mark.parametrize(("model", "kind"), [
    *(("prism3", k) for k in UNDER_ROBOT), ("tetraspine3", "rough"), ("tetraspine3", "wall")])
def test_robot_rests_on_each_terrain_without_falling_through(model, kind):
    p = preset(model)
    terrain = parse_terrain(UNDER_ROBOT[kind])
    structure = p.build()
    compiled = tensim.compile_structure(structure, _world(terrain))
    radius = {n.name: 0.0 for n in structure.nodes}
    for rod in structure.rods:
        for n in rod.nodes:
            radius[n] = max(radius[n], rod.radius)
    geometry = terrain.geometry()
    with Simulation(compiled, controller=p.controller()) as sim:
        assert _node_clearance(sim, geometry, radius) > 0.0  # starts clear of the surface
        lowest, com_z = np.inf, []
        for _ in range(30):  # 1.5 s
            sim.step(50)
            lowest = min(lowest, _node_clearance(sim, geometry, radius))
            com_z.append(sim.data.subtree_com[0][2])
    # MuJoCo's soft contacts let a body sink a few millimetres into the surface it rests on
    assert lowest > -0.01
    assert lowest < 0.02  # ... and it does touch it
    # it has come to rest vertically: a robot that slipped through would still be falling
    assert abs(com_z[-1] - com_z[-10]) < 0.005


# -- contact parameters ---------------------------------------------------------------------


def _sliding_rod_deceleration(terrain: object, rod_friction: float) -> float:
    """Deceleration of a rod sliding along its axis on ``terrain``, in units of g."""
    r = 0.01
    rod = Structure("rod", nodes=(Node("a", (-0.2, 0.0, r)), Node("b", (0.2, 0.0, r))),
                    rods=(Rod("rod", ("a", "b"), r, linear_density=1.0,
                              friction=rod_friction),))
    compiled = tensim.compile_structure(rod, _world(terrain))
    m, d = compiled.model, mujoco.MjData(compiled.model)
    mujoco.mj_step(m, d, 300)  # settle onto the ground
    d.qvel[0] = 2.0
    mujoco.mj_step(m, d, 50)
    v0 = d.qvel[0]
    mujoco.mj_step(m, d, 100)
    return (v0 - d.qvel[0]) / (100 * m.opt.timestep) / 9.81


def test_terrain_friction_replaces_the_rods_and_unset_keeps_it():
    # the terrain's coefficient gives exactly the motion the rod's own would have given
    assert _sliding_rod_deceleration(Flat(friction=0.2), 0.6) == \
        _sliding_rod_deceleration(Flat(), 0.2)
    assert _sliding_rod_deceleration(Wall(friction=0.3, distance=5.0), 0.9) == \
        _sliding_rod_deceleration(Flat(), 0.3)
    # Coulomb sliding decelerates at mu g; MuJoCo's pyramidal friction cone and soft contacts
    # (and the thin rod rocking on its two end contacts) put it within ~12 % of that
    assert _sliding_rod_deceleration(Flat(friction=0.2), 0.6) == pytest.approx(0.2, rel=0.15)
    assert _sliding_rod_deceleration(Flat(), 0.6) == pytest.approx(0.6, rel=0.15)


def _rebound(terrain: object) -> float:
    """Ratio of rebound to impact speed of a small ball dropped on ``terrain``."""
    ball = Structure("ball", nodes=(Node("b", (0.0, 0.0, 0.2)),),
                     point_masses=(PointMass("b", 0.1, 0.02),))
    compiled = tensim.compile_structure(ball, _world(terrain, timestep=1e-4))
    m, d = compiled.model, mujoco.MjData(compiled.model)
    impact = rebound = 0.0
    for _ in range(4000):
        mujoco.mj_step(m, d)
        if rebound == 0.0 and d.qvel[2] < 0:
            impact = min(impact, d.qvel[2])
        else:
            rebound = max(rebound, d.qvel[2])
    return rebound / -impact


def test_terrain_restitution_sets_the_rebound():
    # a soft contact maps restitution to a damping ratio exactly only for a linear spring;
    # MuJoCo's constraint impedance makes it approximate: within 0.1 of e
    assert _rebound(Flat(friction=0.5, restitution=0.6)) == pytest.approx(0.6, abs=0.1)
    assert _rebound(Flat(friction=0.5, restitution=0.3)) == pytest.approx(0.3, abs=0.1)
    assert _rebound(Flat(friction=0.5)) < 0.2  # critically damped contact: barely bounces


def test_flat_default_world_has_just_the_ground_plane():
    compiled = tensim.compile_structure(preset("prism3").build())
    m = compiled.model
    world_geoms = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)
                   for g in range(m.ngeom) if m.geom_bodyid[g] == 0]
    assert world_geoms == ["ground"]
    assert tensim.WorldOptions().terrain == Flat()
    with pytest.raises(ValueError, match="terrain needs ground"):
        tensim.WorldOptions(ground=False, terrain=Wall())


def _sled_slide(angle: float, friction: float) -> float:
    """How far a flat three-rod sled resting on an incline slides down it in 1.5 s [m]."""
    r = 0.01
    corners = {"a": (0.15, 0.0), "b": (-0.075, 0.13), "c": (-0.075, -0.13)}
    sled = Structure("sled", nodes=tuple(Node(k, (x, y, r)) for k, (x, y) in corners.items()),
                     rods=tuple(Rod(a + b, (a, b), r, linear_density=1.0, friction=friction)
                                for a, b in ("ab", "bc", "ca")))
    slope = Slope(angle=angle, start=-2.0, length=4.0)  # the sled sits on the incline
    compiled = tensim.compile_structure(sled, _world(slope))
    m, d = compiled.model, mujoco.MjData(compiled.model)
    mujoco.mj_step(m, d, 300)
    start = d.qpos[:3].copy()
    mujoco.mj_step(m, d, 1500)
    return float(np.linalg.norm(d.qpos[:3] - start))


def test_a_body_holds_on_a_slope_below_its_friction_angle_and_slides_above():
    # Coulomb: at rest while tan(angle) < mu = 0.3, i.e. below 16.7 deg, sliding above it
    assert _sled_slide(14.0, 0.3) < 0.005  # soft contacts creep a little at most
    assert _sled_slide(19.0, 0.3) > 0.1  # (g sin - mu g cos) t^2 / 2 = 0.46 m in 1.5 s
