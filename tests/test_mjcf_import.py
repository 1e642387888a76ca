"""MJCF import: each element against hand-computed values, the actuator mappings, refusals,
the world settings, the round trip through export-mjcf, and the imported robot moving as
MuJoCo moves the file."""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from tensim.cli import main
from tensim.io import MjcfImportWarning, compare_with_mujoco, import_mjcf, to_mjcf
from tensim.io._mjcf_world import restitution
from tensim.model import compile_structure
from tensim.models import preset
from tensim.structure import (
    PASSIVE,
    Cable,
    DCMotor,
    Motor,
    Node,
    PointMass,
    Rod,
    Structure,
    StructureError,
    body_length,
    load_structure,
    mass_properties,
)
from tensim.terrain import restitution_dampratio

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "rolling"


def _doc(bodies: str, tendons: str = "", actuators: str = "", extra: str = "",
         option: str = "") -> str:
    return (f"<mujoco model='t'><option {option}/>{extra}<worldbody>"
            f"<geom name='floor' type='plane' size='5 5 .1'/>{bodies}</worldbody>"
            f"<tendon>{tendons}</tendon><actuator>{actuators}</actuator></mujoco>")


def _imported(xml: str, name: str | None = None):
    return import_mjcf(xml=xml, warn=False, name=name)


def _group(structure: Structure, rod: str):
    group = next(g for g in structure.rigid_groups() if rod in g.rods)
    return mass_properties(structure, group)


# a bar along x from -h to h, two free bodies, so that tendons have somewhere to go
_H, _R = 0.5, 0.02


def _bar(name: str, y: float, body: str = "", geoms: str = "") -> str:
    geoms = geoms or (f"<geom name='{name}' type='capsule' fromto='{-_H} 0 0 {_H} 0 0' "
                      f"size='{_R}' mass='1'/>")
    return (f"<body name='{name}' pos='0 {y} 1'><freejoint/>{geoms}"
            f"<site name='{name}_a' pos='{-_H} 0 0'/><site name='{name}_b' pos='{_H} 0 0'/>"
            f"{body}</body>")


def _two_bars(tendon_attrs: str = "stiffness='300' damping='2' springlength='0 0.5'",
              actuators: str = "", **kwargs: str) -> str:
    return _doc(_bar("p", 0.0) + _bar("q", 0.6),
                f"<spatial name='c' {tendon_attrs}><site site='p_a'/><site site='q_a'/></spatial>",
                actuators, **kwargs)


# -- bodies: rods, end caps, point masses, mass and inertia ------------------------------------


def _capsule_transverse(mass: float, r: float, h: float) -> float:
    """A solid capsule's moment about a transverse axis through its centre: the cylinder's
    m_c (r^2/4 + h^2/3) and the two hemispheres' m_h (83/320 r^2 + (h + 3r/8)^2)."""
    cylinder, balls = math.pi * r**2 * 2 * h, 4 / 3 * math.pi * r**3
    m_c, m_h = mass * cylinder / (cylinder + balls), mass * balls / (cylinder + balls)
    return m_c * (r**2 / 4 + h**2 / 3) + m_h * (83 / 320 * r**2 + (h + 3 * r / 8) ** 2)


def test_capsule_with_end_caps_keeps_mass_and_inertia() -> None:
    caps = (f"<geom name='bar' type='capsule' fromto='{-_H} 0 0 {_H} 0 0' size='{_R}' "
            f"mass='3.2'/><geom name='cap0' type='sphere' size='0.04' pos='{-_H} 0 0' "
            f"mass='0.4'/><geom name='cap1' type='sphere' size='0.04' pos='{_H} 0 0' mass='0.4'/>")
    s = _imported(_doc(f"<body name='b' pos='0 0 1'><freejoint/>{caps}</body>")).structure
    assert [r.name for r in s.rods] == ["bar"] and len(s.point_masses) == 2
    assert {p.node for p in s.point_masses} == {"cap0", "cap1"}  # named after the spheres
    assert all(p.radius == 0.04 for p in s.point_masses)
    props = _group(s, "bar")
    assert props.mass == pytest.approx(4.0, rel=1e-12)
    # transverse moment: the capsule's (its rounded ends included) and the caps' by hand
    hand = _capsule_transverse(3.2, _R, _H) + 2 * 0.4 * (_H**2 + 0.4 * 0.04**2)
    np.testing.assert_allclose(props.principal_moments()[1:], hand, rtol=1e-9)
    # the capsule's rounded ends' mass moved to the end caps: each cap a little over 0.4 kg
    assert all(0.4 < p.mass < 0.45 for p in s.point_masses)


def test_a_capsule_alone_gets_its_rounded_ends_as_end_masses() -> None:
    s = _imported(_doc(_bar("b", 0.0))).structure
    props = _group(s, "b")
    assert props.mass == pytest.approx(1.0, rel=1e-12)
    np.testing.assert_allclose(props.principal_moments()[1:], _capsule_transverse(1.0, _R, _H),
                               rtol=1e-9)
    # the end masses lie inside the rod (radius = the rod's), so they add no contact surface
    assert len(s.point_masses) == 2 and all(p.radius == _R for p in s.point_masses)


def test_a_cylinder_of_given_density_is_a_rod_of_that_density() -> None:
    geoms = f"<geom type='cylinder' fromto='{-_H} 0 0 {_H} 0 0' size='{_R}' density='700'/>"
    s = _imported(_doc(_bar("b", 0.0, geoms=geoms))).structure
    # tensim's rod is a solid cylinder: the file's, exactly, and no end masses needed
    assert s.rods[0].mass_per_length() == pytest.approx(700 * math.pi * _R**2, rel=1e-12)
    assert s.point_masses == ()
    assert s.rods[0].name == "b"  # an unnamed geom: the rod takes its body's name


def test_an_explicit_inertial_heavier_at_the_ends_puts_mass_at_the_ends() -> None:
    length, mass = 2 * _H, 2.0
    uniform = mass * (3 * _R**2 + length**2) / 12
    transverse, axial = 1.5 * uniform, 0.5 * mass * _R**2
    geoms = (f"<inertial pos='0 0 0' mass='{mass}' diaginertia='{axial} {transverse} "
             f"{transverse}'/><geom type='cylinder' fromto='{-_H} 0 0 {_H} 0 0' size='{_R}'/>")
    s = _imported(_doc(_bar("b", 0.0, geoms=geoms))).structure
    # by hand: m_rod + 2 m_end = M and m_rod (3r^2 + L^2)/12 + 2 m_end (L^2/4 + 0.4 r^2) = I
    a = np.array([[1.0, 2.0], [(3 * _R**2 + length**2) / 12, 2 * (length**2 / 4 + 0.4 * _R**2)]])
    m_rod, m_end = np.linalg.solve(a, [mass, transverse])
    assert s.rods[0].mass_per_length() * length == pytest.approx(m_rod, rel=1e-6)
    np.testing.assert_allclose([p.mass for p in s.point_masses], m_end, rtol=1e-6)
    np.testing.assert_allclose(_group(s, "b").principal_moments()[1:], transverse, rtol=1e-6)


def test_a_site_between_the_ends_splits_the_rod_into_one_rigid_body() -> None:
    mid = "<site name='mid' pos='0.1 0 0'/>"
    xml = _doc(_bar("p", 0.0, body=mid) + _bar("q", 0.6),
               "<spatial name='c' stiffness='100'><site site='mid'/><site site='q_a'/></spatial>")
    s = _imported(xml).structure
    assert sorted(r.name for r in s.rods) == ["p_0", "p_1", "q"]
    assert len(s.rigid_groups()) == 2  # the halves share node 'mid': one body
    whole = _imported(_doc(_bar("p", 0.0))).structure
    split = _group(s, "p_0")
    assert split.mass == pytest.approx(1.0, rel=1e-12)
    # the transverse moments (the axial one of a thin rod is tensim's to raise)
    np.testing.assert_allclose(split.principal_moments()[1:],
                               _group(whole, "p").principal_moments()[1:], rtol=1e-9)
    np.testing.assert_allclose(split.com, _group(whole, "p").com, atol=1e-12)
    assert s.cable("c").nodes == ("mid", "q_a")


def test_a_split_bar_keeps_its_whole_length_as_the_body_length() -> None:
    """Rods split at a site (or at an imported sleeve's ends) are one bar: the speed's unit is
    the bar, end to end, not its longest piece; bars at an angle stay apart."""
    mid = "<site name='mid' pos='0.1 0 0'/>"
    xml = _doc(_bar("p", 0.0, body=mid) + _bar("q", 0.6),
               "<spatial name='c' stiffness='100'><site site='mid'/><site site='q_a'/></spatial>")
    s = _imported(xml).structure
    assert max(s.distance(*r.nodes) for r in s.rods) == pytest.approx(2 * _H)  # bar q
    split = dataclasses.replace(s, rods=tuple(r for r in s.rods if r.name != "q"))
    assert max(split.distance(*r.nodes) for r in split.rods) == pytest.approx(_H + 0.1)
    assert body_length(split) == pytest.approx(2 * _H, abs=1e-12)
    bent = Structure("bent", (Node("a", (0, 0, 0)), Node("b", (0.6, 0, 0)),
                              Node("c", (0.6, 0.5, 0))),
                     (Rod("ab", ("a", "b"), 0.01, linear_density=1.0), Rod("bc", ("b", "c"), 0.01,
                                                                  linear_density=1.0)), ())
    assert body_length(bent) == pytest.approx(0.6)


def test_a_site_on_an_end_caps_outside_anchors_at_the_cap() -> None:
    """Labs anchor cables on an end cap's surface, off the bar's axis: within one radius of a
    geom's surface a site goes to the nearest node (here the cap's centre, the bar's end) and
    the move is noted; further out it is refused (the refusals below)."""
    cap = (f"<geom type='capsule' fromto='{-_H} 0 0 {_H} 0 0' size='{_R}' mass='1'/>"
           f"<geom name='cap' type='sphere' pos='{_H} 0 0' size='0.05' mass='0.1'/>")
    rim = f"<site name='rim' pos='{_H - 0.02} 0.05 0'/>"  # 0.054 m from the cap's centre
    xml = _doc(_bar("p", 0.0, geoms=cap, body=rim) + _bar("q", 0.6),
               "<spatial name='c' stiffness='100'><site site='rim'/><site site='q_a'/></spatial>")
    result = _imported(xml)
    s = result.structure
    c = s.cable("c")
    assert s.position(c.nodes[0]) == pytest.approx((_H, 0.0, 1.0))
    assert any("moved onto" in n and "0.0539 m" in n for n in result.notes)
    # the cable keeps the file's length between its anchors: the move lengthened it by
    # |q_a - rim| - |q_a - cap|, shared between its two anchors
    q_a = np.array([-_H, 0.6, 1.0])
    file_length = float(np.linalg.norm(q_a - [_H - 0.02, 0.05, 1.0]))
    assert s.distance(*c.nodes) - 2 * c.anchor_offset == pytest.approx(file_length, abs=1e-9)
    assert any("anchor_offset" in n for n in result.notes)


def test_sites_become_nodes_and_a_site_between_tendon_ends_a_via_node() -> None:
    ball = "<body name='v' pos='0 0.3 1.4'><freejoint/><geom type='sphere' size='0.03' " \
           "mass='0.2'/><site name='eye' pos='0 0 0.01'/></body>"
    xml = _doc(_bar("p", 0.0) + _bar("q", 0.6) + ball,
               "<spatial name='c' stiffness='100'><site site='p_a'/><site site='eye'/>"
               "<site site='q_b'/></spatial>")
    result = _imported(xml)
    s = result.structure
    assert s.cable("c").nodes == ("p_a", "q_b") and s.cable("c").via == ("eye",)
    assert s.node("eye").position == pytest.approx((0.0, 0.3, 1.4))  # onto the sphere's centre
    assert [p.mass for p in s.point_masses if p.node == "eye"] == [pytest.approx(0.2)]
    assert any("moved onto" in n for n in result.notes)


def test_a_body_without_a_joint_is_fixed_and_world_sites_are_anchors() -> None:
    xml = _doc("<site name='hook' pos='0 0 2'/>" + _bar("p", 0.0).replace("<freejoint/>", ""),
               "<spatial name='c' stiffness='100'><site site='hook'/><site site='p_a'/>"
               "</spatial>")
    s = _imported(xml).structure
    assert s.node("hook").fixed and s.node("p_a").fixed
    assert all(g.fixed for g in s.rigid_groups())


def test_geoms_for_looks_and_the_worlds_geoms_are_left_out_and_named() -> None:
    looks = "<geom name='shell' type='mesh' mesh='m' mass='0' contype='0' conaffinity='0'/>"
    xml = _doc(_bar("p", 0.0, body=looks) + "<geom name='post' type='capsule' size='.05 .5'/>",
               extra="<asset><mesh name='m' vertex='0 0 0 1 0 0 0 1 0 0 0 1'/></asset>")
    result = _imported(xml)
    assert _group(result.structure, "p").mass == pytest.approx(1.0)
    assert any("geoms ['shell'] have no mass and no contact" in n for n in result.notes)
    assert any("the world's other geoms (1" in n for n in result.notes)


# -- tendons: cables ---------------------------------------------------------------------------


def test_a_tendon_spring_becomes_the_cable() -> None:
    s = _imported(_two_bars()).structure
    c = s.cable("c")
    assert (c.stiffness, c.damping, c.rest_length) == (300.0, 2.0, 0.5)
    assert c.motor.passive and c.nodes == ("p_a", "q_a")


def test_a_spring_without_a_dead_band_is_noted_and_rests_at_its_length() -> None:
    result = _imported(_two_bars("stiffness='300'"))
    assert result.structure.cable("c").rest_length == pytest.approx(0.6)  # length at qpos0
    assert any("also pushes below 0.6 m" in n for n in result.notes)


# -- actuators: motors -------------------------------------------------------------------------


def test_a_filtered_force_actuator_beside_a_spring_maps_to_rest_lengths() -> None:
    act = "<general name='a' tendon='c' dyntype='filter' dynprm='0.1' gainprm='400' " \
          "ctrlrange='-1 0'/>"
    result = _imported(_two_bars("stiffness='10000' damping='50' springlength='0 0.55' "
                                 "limited='true' range='0.2 2'", act))
    mapping, c = result.actuators[0], result.structure.cable("c")
    assert mapping.kind == "force" and mapping.cable == "c"
    # tension k (x - l0) + 400 |u|  ==  k (x - (l0 + 0.04 u)): rest = 0.55 + 0.04 u
    assert mapping.command.offset == pytest.approx(0.55)
    assert mapping.command.scale == pytest.approx(400 / 10000)
    assert c.rest_length == pytest.approx(0.55)  # ctrl starts at 0
    assert c.motor.min_rest_length == pytest.approx(0.2)  # reels in as far as the pull folds
    # the rest length is linear in the filtered input: the filter is the motor's lag, and the
    # cable may move as fast as the robot lets it (the span in one step)
    assert c.motor.lag_time == pytest.approx(0.1)
    assert c.motor.max_speed == pytest.approx(400 / 10000 / result.world.timestep)
    assert c.motor.max_tension == pytest.approx(400 + 10000 * 0.05)  # pull + build stretch
    assert c.motor.min_length == pytest.approx(0.2)  # the tendon's lower limit
    text = " ".join(result.notes)
    for gap in ("time constant 0.1 s", "still pulls", "stretched past its build length",
                "never above the spring's 0.55 m",
                "upper length limit 2 m"):
        assert gap in text
    assert all(n.startswith("actuator 'a'") for n in result.notes if "filter" in n)


def test_file_controls_become_a_controllers_rest_lengths() -> None:
    result = import_mjcf(EXAMPLES / "three_bar_lab.xml", warn=False)
    rest = result.rest_lengths({"act_top1": -0.5})
    assert sorted(rest) == ["bottom0", "bottom1", "bottom2", "top0", "top1", "top2"]
    assert rest["top1"] == pytest.approx(0.853035 - 0.5 * 400 / 10000)
    assert rest["top0"] == pytest.approx(0.853035)  # the others keep their start
    with pytest.raises(KeyError, match="no actuator 'act_vertical0'"):
        result.rest_lengths({"act_vertical0": -1.0})


def test_a_plain_motor_with_a_gear_acts_at_once() -> None:
    result = _imported(_two_bars("stiffness='1000' springlength='0 0.55'",
                                 "<motor name='m' tendon='c' gear='2' ctrlrange='-50 10'/>"))
    m = result.actuators[0]
    assert m.command.scale == pytest.approx(2 / 1000)
    assert m.motor.max_tension == pytest.approx(100 + 1000 * 0.05)  # 2 x 50 N on the build 50 N
    assert m.motor.max_speed == pytest.approx((100 + 20) / 1000 / 0.002)  # the range in a step
    assert any("acts at once" in n for n in result.notes)


def test_a_position_servo_beside_a_spring_is_a_pd_motor() -> None:
    act = ("<position name='s' tendon='c' kp='500' kv='10' gear='2' ctrlrange='0.6 1.2' "
           "forcerange='-60 0'/>")
    result = _imported(_two_bars("stiffness='1000' damping='1' springlength='0 0.5'", act))
    m, c = result.actuators[0], result.structure.cable("c")
    # gear g: tension g^2 kp (x - u/g) + g^2 kv xdot, clamped to [0, g x 60 N]; the spring
    # keeps its own cable (1000 N/m, rest 0.5 m)
    assert (c.stiffness, c.damping, c.rest_length) == (1000.0, 1.0, 0.5)
    assert (c.motor.pd_stiffness, c.motor.pd_damping) == (4 * 500.0, 4 * 10.0)
    assert c.motor.max_tension == pytest.approx(120.0)
    assert (m.command.offset, m.command.scale) == (0.0, 0.5)  # target L = u / g
    assert c.motor.pd_target == pytest.approx(0.3)  # ctrl 0 clamps to 0.6
    assert not any("pushes" in n for n in result.notes)  # the force range only pulls
    pushing = _imported(_two_bars("stiffness='1000'", act.replace("-60 0", "-60 60")))
    assert any("also pushes" in n for n in pushing.notes)


def test_a_general_servo_whose_gain_is_not_its_stiffness_scales_its_target() -> None:
    """``general`` with gain g and bias [b0, -kp, -kv]: force g u + b0 - kp L - kv Ldot, a PD
    with the target L = (g u + b0) / kp (labs write g and kp apart: 6667 and 6666)."""
    act = ("<general name='g' tendon='c' gaintype='fixed' gainprm='600' biastype='affine' "
           "biasprm='300 -500 -10' ctrlrange='0.2 0.9' forcelimited='true' forcerange='-80 0'/>")
    result = _imported(_two_bars("stiffness='1000' springlength='0 0.5'", act))
    m, c = result.actuators[0], result.structure.cable("c")
    assert m.kind == "position"
    assert (c.motor.pd_stiffness, c.motor.pd_damping) == (500.0, 10.0)
    assert (m.command.offset, m.command.scale) == pytest.approx((300 / 500, 600 / 500))
    assert c.motor.pd_target == pytest.approx(0.6 + 1.2 * 0.2)  # ctrl 0 clamps to 0.2
    assert c.motor.max_tension == pytest.approx(80.0)
    # without a spring: one cable of the servo's stiffness, rest length the target
    alone = _imported(_two_bars("damping='1'", act)).structure.cable("c")
    assert alone.stiffness == pytest.approx(500.0)
    assert alone.rest_length == pytest.approx(0.6 + 1.2 * 0.2)


def test_a_servo_beside_a_slack_spring_moves_as_mujoco_moves_the_file(tmp_path) -> None:
    """Weightless bars pulled together by a tension-only servo (its spring slack, its target
    from the keyframe): they overshoot, the servo lets go, the damper's pull returns. tensim's
    PD motor is the file's actuator: the runs differ only by the integrators' first-order
    error, which shrinks with the step (measured: 6.2 mm at 2 ms, 1.5 mm at 0.5 ms, on 0.3 m
    of travel); a servo that may also push (which tensim's never does) stays 0.2 m apart."""
    def run(step: str, forces: str = "-100 0"):
        act = (f"<position name='s' tendon='c' kp='500' kv='5' ctrlrange='0.3 0.8' "
               f"forcerange='{forces}'/>")
        xml = _two_bars("stiffness='1000' springlength='0 0.7'", act,
                        option=f"gravity='0 0 0' timestep='{step}'")
        path = tmp_path / "servo.xml"
        path.write_text(xml.replace("</mujoco>", "<keyframe><key ctrl='0.45'/></keyframe>"
                                    "</mujoco>"))
        return compare_with_mujoco(path, 1.0)

    coarse, fine = run("0.002"), run("0.0005")
    assert coarse.max_displacement > 0.2  # the ends do move
    assert fine.max_difference < 2.5e-3 and coarse.max_difference > 3 * fine.max_difference
    assert run("0.002", "-100 100").max_difference > 0.1


def test_a_force_limited_servo_alone_on_its_tendon_saturates_as_the_file(tmp_path) -> None:
    """A servo without a tendon spring whose target lies far inside the tendon: its pull is
    clamped at the force limit (20 N, where kp x the error is 150 N). tensim's motor
    saturates (pays out to hold the cap), and the bars close as MuJoCo closes them; a motor
    that only stopped reeling would pull 150 N. (kv 0: the file clamps the servo's damping
    with its pull, tensim's damping acts on top of the cap, as the note says.)"""
    act = ("<position name='s' tendon='c' kp='500' kv='0' ctrlrange='0.3 0.8' "
           "forcerange='-20 0'/>")
    xml = _two_bars("damping='1'", act, option="gravity='0 0 0' timestep='0.0005'")
    result = _imported(xml)
    assert result.structure.cable("c").motor.saturate
    assert any("saturates at 20 N" in n for n in result.notes)
    path = tmp_path / "servo.xml"
    path.write_text(xml.replace("</mujoco>", "<keyframe><key ctrl='0.3'/></keyframe></mujoco>"))
    agreement = compare_with_mujoco(path, 0.05)  # until just before the target (0.1 s)
    assert agreement.max_displacement > 0.05  # 20 N on 2 kg of bars: they close
    assert agreement.max_difference < 0.03 * agreement.max_displacement  # measured: 1.8 %


def test_an_integrated_velocity_servo_is_a_motor_of_that_speed() -> None:
    act = "<intvelocity name='iv' tendon='c' kp='100' actrange='0.3 0.9' ctrlrange='-0.2 0.2'/>"
    result = _imported(_two_bars("stiffness='1000' springlength='0 0.55'", act))
    m, c = result.actuators[0], result.structure.cable("c")
    # k = 1000 + 100; rest = (1000 x 0.55 + 100 act) / 1100; act starts at 0, clamped to 0.3
    assert m.kind == "position" and m.command.rate and c.stiffness == pytest.approx(1100.0)
    assert c.rest_length == pytest.approx((550 + 30) / 1100)
    assert c.motor.min_rest_length == pytest.approx((550 + 30) / 1100)
    assert c.motor.max_speed == pytest.approx(0.2 * 100 / 1100)  # |ctrl| x d(rest)/d(act)


def test_a_keyframe_sets_the_starting_targets() -> None:
    act = "<position name='s' tendon='c' kp='2000' ctrlrange='0.3 0.9'/>"
    xml = _two_bars("damping='1'", act).replace(
        "</mujoco>", "<keyframe><key name='home' ctrl='0.58'/></keyframe></mujoco>")
    result = _imported(xml)
    assert result.structure.cable("c").rest_length == pytest.approx(0.58)
    assert result.structure.cable("c").stiffness == pytest.approx(2000.0)
    assert any("keyframe 'home'" in n for n in result.notes)


def test_a_velocity_servo_leaves_the_cable_passive_and_says_so() -> None:
    result = _imported(_two_bars(actuators="<velocity name='v' tendon='c' kv='30'/>"))
    assert result.structure.cable("c").motor.passive
    assert result.actuators[0].kind == "unsupported"
    assert any("actuator 'v'" in n and "chosen: a passive cable" in n for n in result.notes)


def test_notes_are_also_warnings() -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = import_mjcf(xml=_two_bars(actuators="<velocity name='v' tendon='c' kv='30'/>"))
    assert [str(w.message) for w in caught] == [f"<string>: {n}" for n in result.notes]
    assert all(w.category is MjcfImportWarning for w in caught)


# -- refusals ----------------------------------------------------------------------------------


@pytest.mark.parametrize(("xml", "item", "words"), [
    (_doc(_bar("p", 0.0).replace("<freejoint/>", "<joint name='j' type='hinge'/>")),
     "body 'p'", "hinge joint 'j'"),
    (_doc(_bar("p", 0.0, body="<body name='child'><geom size='0.1'/></body>")),
     "body 'child'", "nested in body 'p'"),
    (_doc(_bar("p", 0.0, geoms="<geom name='brick' type='box' size='.1 .1 .1'/>")),
     "geom 'brick'", "is a box"),
    (_doc(_bar("p", 0.0, geoms="<geom name='hull' type='mesh' mesh='m'/>"), extra=(
        "<asset><mesh name='m' vertex='0 0 0 1 0 0 0 1 0 0 0 1'/></asset>")),
     "geom 'hull'", "is a mesh"),
    (_doc(_bar("p", 0.0, body="<geom name='drum' type='cylinder' size='.05 .05'/>") +
          _bar("q", 0.6), "<spatial name='c' stiffness='1'><site site='p_a'/>"
          "<geom geom='drum'/><site site='q_a'/></spatial>"),
     "tendon 'c'", "wraps a cylinder"),
    (_two_bars(actuators="<general name='g' site='p_a'/>"), "actuator 'g'", "acts on a site"),
    (_two_bars(actuators="<motor name='m1' tendon='c'/><motor name='m2' tendon='c'/>"),
     "tendon 'c'", "2 actuators"),
    (_two_bars("damping='1'"), "tendon 'c'", "no spring"),
    (_doc(_bar("p", 0.0).replace("<freejoint/>", "").replace("mass='1'", "mass='0'")),
     "body 'p'", "has no mass"),
    (_two_bars("damping='1'", "<velocity name='v' tendon='c' kv='3'/>"), "actuator 'v'",
     "no spring"),
    (_two_bars("damping='1'", "<motor name='m' tendon='c'/>"), "actuator 'm'", "no spring"),
    (_doc(_bar("p", 0.0, body="<site name='off' pos='0 0.3 0'/>") + _bar("q", 0.6),
          "<spatial name='c' stiffness='1'><site site='off'/><site site='q_a'/></spatial>"),
     "body 'p'", "site 'off'"),
])
def test_what_is_not_a_tensegrity_is_refused_naming_file_and_element(xml, item, words,
                                                                      tmp_path) -> None:
    path = tmp_path / "robot.xml"
    path.write_text(xml)
    with pytest.raises(StructureError) as err:
        import_mjcf(path, warn=False)
    assert str(err.value).startswith(f"{path}: {item}: ")
    assert words in str(err.value)


def test_a_file_mujoco_cannot_read_is_refused(tmp_path) -> None:
    path = tmp_path / "bad.xml"
    path.write_text("<mujoco><worldbody><body><geom type='capsule'/></worldbody></mujoco>")
    with pytest.raises(StructureError, match=f"{path}: MuJoCo cannot read it"):
        import_mjcf(path)
    with pytest.raises(FileNotFoundError, match="no such MJCF file"):
        import_mjcf(tmp_path / "missing.xml")


# -- world and contact -------------------------------------------------------------------------


def test_contact_and_options_are_carried_as_mujoco_mixes_them() -> None:
    geoms = (f"<geom type='capsule' fromto='{-_H} 0 0 {_H} 0 0' size='{_R}' mass='1' "
             "friction='0.7 0.01 0.001' condim='4' solref='0.03 0.5'/>")
    xml = _doc(_bar("p", 0.0, geoms=geoms), option="timestep='0.002' cone='elliptic' "
               "noslip_iterations='3' integrator='RK4'").replace(
        "type='plane' size='5 5 .1'", "type='plane' size='5 5 .1' friction='0.5'")
    result = _imported(xml)
    w, rod = result.world, result.structure.rods[0]
    assert (w.timestep, w.cone, w.noslip_iterations, w.condim) == (0.002, "elliptic", 3, 4)
    # equal priority: the larger friction and condim; solref the mean (solmix 1 each)
    assert rod.friction == 0.7 and w.torsional_friction == 0.01
    assert w.contact_timeconst == pytest.approx(0.025)
    zeta = 0.75
    assert rod.restitution == pytest.approx(math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)))
    assert any("integrates with rk4" in n for n in result.notes)
    assert result.command_line() == "--dt 0.002 --contact cone=elliptic,noslip=3,condim=4," \
                                    "torsional=0.01"


def test_a_direct_contact_solref_is_replaced_once_and_said_once() -> None:
    geoms = (f"<geom type='capsule' fromto='{-_H} 0 0 {_H} 0 0' size='{_R}' mass='1' "
             "solref='-5000 -500'/><geom name='cap' type='sphere' pos='0.5 0 0' size='0.03' "
             "mass='0.1' solref='-5000 -500'/>")
    result = _imported(_doc(_bar("p", 0.0, geoms=geoms)).replace(
        "type='plane' size='5 5 .1'", "type='plane' size='5 5 .1' solref='-5000 -500'"))
    said = [n for n in result.notes if "direct contact solref" in n]
    assert len(said) == 1 and "[-5000.0, -500.0]" in said[0] and "geom 'cap'" in said[0]
    assert result.world.contact_timeconst == 0.02


@pytest.mark.parametrize("e", [0.0, 0.1, 0.5, 0.9])
def test_restitution_inverts_the_damping_ratio_tensim_builds(e) -> None:
    assert restitution(restitution_dampratio(e)) == pytest.approx(e, abs=1e-12)


def test_a_step_too_long_for_the_cables_is_named_with_one_that_holds() -> None:
    ball = "<body name='{0}' pos='{1} 0 1'><freejoint/><geom type='sphere' size='0.05' " \
           "mass='0.5'/><site name='{0}s' pos='0 0 0'/></body>"
    xml = _doc(ball.format("a", 0) + ball.format("b", 1),
               "<spatial name='c' stiffness='{k}' springlength='0 0.9'><site site='as'/>"
               "<site site='bs'/></spatial>", option="timestep='0.002'")
    # two masses m on a spring k: omega^2 = 2 k / m, Euler stable below 2 / omega
    soft = _imported(xml.replace("{k}", "100"))
    assert soft.max_step == pytest.approx(2 / math.sqrt(2 * 100 / 0.5), rel=1e-6)
    assert not any("--dt" in n for n in soft.notes)
    stiff = _imported(xml.replace("{k}", "4e6"))  # 2 / sqrt(2 x 4e6 / 0.5) = 0.5 ms
    assert stiff.max_step == pytest.approx(5e-4, rel=1e-6)
    assert any("the file's 0.002 s does not hold it; run with --dt 0.0002" in n
               for n in stiff.notes)


# -- round trip --------------------------------------------------------------------------------


def _routed() -> Structure:
    nodes = (Node("a0", (0.0, 0.0, 0.3)), Node("a1", (0.0, 0.3, 0.3)),
             Node("b0", (0.5, 0.0, 0.3)), Node("b1", (0.5, 0.3, 0.3)),
             Node("v", (0.25, 0.15, 0.5)))
    rods = (Rod("ra", ("a0", "a1"), 0.01, linear_density=0.2),
            Rod("rb", ("b0", "b1"), 0.01, linear_density=0.2))
    cables = (Cable("c", ("a0", "b1"), 100.0, damping=1.0, pretension=2.0, via=("v",)),)
    return Structure("routed", nodes, rods, cables, (PointMass("v", 0.05, 0.01),))


def _motor_numbers(cable: Cable) -> list[float]:
    """A cable's motor as numbers (its DC motor's too)."""
    motor = dataclasses.asdict(cable.motor)
    dc = motor.pop("dc") or {}
    return [-1.0 if v is None else float(v) for v in (*motor.values(), *dc.values())]


def _same(a: Structure, b: Structure) -> None:
    """The same robot: nodes (by name and position), rods, point masses, cables, motors and
    every rigid body's mass properties, to the 6 digits MuJoCo's writer keeps."""
    for n in a.nodes:
        np.testing.assert_allclose(b.node(n.name).position, n.position, atol=2e-6)
    rods = {r.name: r for r in b.rods}
    for r in a.rods:
        assert set(rods[r.name].nodes) == set(r.nodes)
        assert (rods[r.name].radius, rods[r.name].friction) == (r.radius, r.friction)
        assert rods[r.name].mass_per_length() == pytest.approx(r.mass_per_length(), rel=1e-5)
    masses = {p.node: p for p in b.point_masses}
    assert set(masses) == {p.node for p in a.point_masses}
    for p in a.point_masses:
        assert (masses[p.node].mass, masses[p.node].radius) == (pytest.approx(p.mass, rel=1e-5),
                                                                p.radius)
    for c in a.cables:
        got = b.cable(c.name)
        assert (got.nodes, got.via) == (c.nodes, c.via)
        assert (got.stiffness, got.damping) == (c.stiffness, c.damping)
        assert got.rest_length == pytest.approx(a.rest_length(c), rel=1e-5)
        assert _motor_numbers(got) == pytest.approx(_motor_numbers(c), rel=1e-5)
        assert (got.motor.passive, got.motor.dc is None) == (c.motor.passive, c.motor.dc is None)
    for ga, gb in zip(a.rigid_groups(), b.rigid_groups(), strict=True):
        pa, pb = mass_properties(a, ga), mass_properties(b, gb)
        assert pb.mass == pytest.approx(pa.mass, rel=1e-5)
        np.testing.assert_allclose(pb.inertia, pa.inertia, rtol=1e-4, atol=1e-9)


def _motors_of_each_kind() -> Structure:
    """prism3 with a DC motor on one cable, no motor on another, a lagged saturating motor
    and PD motors (with and without a starting target)."""
    s = preset("prism3").build()
    dc = Motor(max_tension=400.0, dc=DCMotor(stall_torque=0.8, back_drivable=False))
    cables = list(s.cables)
    cables[0] = dataclasses.replace(cables[0], motor=dc)
    cables[1] = dataclasses.replace(cables[1], motor=PASSIVE)
    cables[2] = dataclasses.replace(cables[2], motor=Motor(lag_time=0.1, saturate=True))
    cables[3] = dataclasses.replace(cables[3], motor=Motor(pd_stiffness=900.0, pd_damping=3.0,
                                                           pd_target=0.2))
    cables[4] = dataclasses.replace(cables[4], motor=Motor(pd_stiffness=500.0))
    return dataclasses.replace(s, cables=tuple(cables))


@pytest.mark.parametrize("name", ["prism3", "six_bar", "routed", "motors"])
def test_export_then_import_gives_the_same_structure(name) -> None:
    structure = {"routed": _routed, "motors": _motors_of_each_kind}.get(
        name, lambda: preset(name).build())()
    compiled = compile_structure(structure)
    for springs in (True, False):
        back = _imported(to_mjcf(compiled, springs=springs))
        _same(compiled.structure, back.structure)
        assert back.notes == tuple(n for n in back.notes if "tendon" in n or "thin" in n)


def test_an_anchor_offset_survives_the_round_trip() -> None:
    """The export puts an offset cable's sites on its anchors; the import moves them onto the
    nodes and gives the offset back through the file's length (to its 6 digits)."""
    s = preset("prism3").build()
    cables = list(s.cables)
    cables[0] = dataclasses.replace(cables[0], anchor_offset=0.01)
    compiled = compile_structure(dataclasses.replace(s, cables=tuple(cables)))
    back = _imported(to_mjcf(compiled)).structure
    assert back.cables[0].anchor_offset == pytest.approx(0.01, abs=1e-6)
    assert [c.anchor_offset for c in back.cables[1:]] == [0.0] * (len(cables) - 1)


def test_round_trip_through_the_commands(tmp_path, capsys) -> None:
    xml, out = tmp_path / "prism.xml", tmp_path / "prism.yaml"
    assert main(["export-mjcf", "prism3", "--out", str(xml)]) == 0
    assert main(["import-mjcf", str(xml), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {out}: 6 nodes, 3 rods in 3 rigid bodies, 9 cables (9 with motors)" in printed
    _same(compile_structure(preset("prism3").build()).structure, load_structure(out))
    assert out.read_text().startswith("# imported from prism.xml by tensim import-mjcf\n")


# -- the example files -------------------------------------------------------------------------


def test_the_three_bar_example_imports_as_described(tmp_path, capsys) -> None:
    out = tmp_path / "three_bar.yaml"
    assert main(["import-mjcf", str(EXAMPLES / "three_bar_lab.xml"), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "9 cables (6 with motors), 12 kg" in printed
    assert "rest-length command = 0.853035 + 0.04 x ctrl [m]" in printed
    s = load_structure(out)
    assert s == import_mjcf(EXAMPLES / "three_bar_lab.xml", warn=False).structure
    assert all(s.distance(*r.nodes) == pytest.approx(1.376, abs=2e-6) for r in s.rods)
    assert all(c.stiffness == 10000.0 for c in s.cables)
    assert [c.motor.passive for c in s.cables] == [False] * 6 + [True] * 3


def test_the_six_bar_example_imports_with_24_servo_motors() -> None:
    result = import_mjcf(EXAMPLES / "six_bar_lab.xml", warn=False)
    s = result.structure
    assert (len(s.rods), len(s.cables), len(result.actuators)) == (6, 24, 24)
    assert all(a.kind == "position" for a in result.actuators)
    assert all(c.stiffness == 2000.0 and c.rest_length == pytest.approx(0.704847)
               for c in s.cables)  # kp, and the keyframe's targets
    assert result.world.timestep == 0.002 and result.world.condim == 4


@pytest.mark.parametrize(("controls", "bound"), [
    ({}, 1e-3),  # passive: the same robot; the integrators (Euler, implicitfast) differ a little
    ({"act_bottom0": -0.1}, 1e-3),  # 40 N pull, its cable taut: the file's filter is the motor's
    # lag, so the two agree on the way too (with a speed limit of the span over tau instead,
    # 4 mm apart on the way)
])
def test_the_imported_three_bar_moves_as_mujoco_moves_the_file(controls, bound) -> None:
    agreement = compare_with_mujoco(EXAMPLES / "three_bar_lab.xml", 3.0, controls)
    assert agreement.duration == pytest.approx(3.0)
    assert agreement.max_displacement > 2e-2  # the comparison is not trivial: the prism sags
    assert agreement.max_difference < bound
    assert agreement.final_difference < 5e-4  # settled: 0.5 mm against 2 cm of sag


def test_a_pull_that_slackens_its_spring_parts_the_two_as_the_notes_say() -> None:
    # 200 N on a bottom cable of the soft prism: the file's spring goes slack while its actuator
    # still pulls, tensim's cable pulls nothing once slack: the robots settle centimetres apart
    agreement = compare_with_mujoco(EXAMPLES / "three_bar_lab.xml", 1.0, {"act_bottom0": -0.5})
    assert agreement.final_difference > 1e-2


def test_import_compare_command(tmp_path, capsys) -> None:
    out = tmp_path / "six.yaml"
    assert main(["import-mjcf", str(EXAMPLES / "six_bar_lab.xml"), "--out", str(out),
                 "--compare", "0.5"]) == 0
    assert "compared with MuJoCo's own run of the file over 0.5 s" in capsys.readouterr().out
    with pytest.raises(KeyError, match="no actuator 'nope'"):
        compare_with_mujoco(EXAMPLES / "six_bar_lab.xml", 0.1, {"nope": 1.0})
