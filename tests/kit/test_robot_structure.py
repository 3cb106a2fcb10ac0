"""kit.robot_structure: drive wheels found by structure, whatever the robot calls them.

Each test builds the URDF shape a reviewer's robot may have (casters, mimic joints, revolute
wheels with wide limits, axes given as −y or in a rotated joint frame, base_footprint or
base_link at the root, a suspension between base and wheel) and checks what is found, or that
the message names the file, the joints and what was expected. The wheel geometry is checked
against numbers computed here by hand from the shapes (and, for a mesh wheel, against the
mesh trimesh generated).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from kit import robot_structure, robots, urdf
from kit.urdf import RobotDescriptionError

HALF_PI = math.pi / 2


def link(name: str, shape: str = "", origin: str = "0 0 0", rpy: str = "0 0 0",
         kind: str = "collision") -> str:
    body = (f"<{kind}><origin xyz='{origin}' rpy='{rpy}'/><geometry>{shape}</geometry>"
            f"</{kind}>") if shape else ""
    return f"<link name='{name}'>{body}</link>"


def joint(name: str, jtype: str, parent: str, child: str, xyz: str = "0 0 0",
          rpy: str = "0 0 0", axis: str = "0 1 0", extra: str = "") -> str:
    return (f"<joint name='{name}' type='{jtype}'><parent link='{parent}'/><child link='{child}'/>"
            f"<origin xyz='{xyz}' rpy='{rpy}'/><axis xyz='{axis}'/>{extra}</joint>")


def wheel(name: str, y: float, x: float = 0.0, radius: float = 0.05, parent: str = "base_link",
          jtype: str = "continuous", axis: str = "0 1 0", rpy: str = "0 0 0", extra: str = "",
          shape: str | None = None, shape_rpy: str = f"{HALF_PI} 0 0") -> str:
    geometry = shape if shape is not None else f"<cylinder radius='{radius}' length='0.03'/>"
    return link(f"{name}_link", geometry, rpy=shape_rpy) + \
        joint(f"{name}_joint", jtype, parent, f"{name}_link", f"{x} {y} 0", rpy, axis, extra)


def robot(*parts: str, base: str = "base_link",
          base_shape: str = "<box size='0.4 0.3 0.1'/>") -> str:
    return f"<robot name='r'>{link(base, base_shape)}{''.join(parts)}</robot>"


def wheels_of(text: str, base: str = "base_link", **kw: object) -> robot_structure.Wheels:
    model = urdf.parse(text, "r.urdf")
    return robot_structure.find_wheels(model, base, **kw)  # type: ignore[arg-type]


def test_two_continuous_wheels_about_y_are_found_with_their_radius_and_separation():
    w = wheels_of(robot(wheel("wheel_left", 0.15), wheel("wheel_right", -0.15)))
    assert (w.right, w.left) == ("wheel_right_joint", "wheel_left_joint")
    assert (w.radius, w.separation) == (0.05, 0.3)
    assert w.axle.tolist() == [0.0, 0.0]


def test_names_do_not_matter_and_a_misleading_name_is_reported():
    w = wheels_of(robot(wheel("a", 0.15), wheel("left_drive", -0.15)))
    assert (w.right, w.left) == ("left_drive_joint", "a_joint")
    assert any("'left_drive_joint' is at y = -0.150 m: the right wheel in REP-103" in n
               for n in w.notes)


@pytest.mark.parametrize("jtype, extra", [
    ("revolute", "<limit lower='-1e9' upper='1e9' effort='1' velocity='12'/>"),
    ("revolute", f"<limit lower='{-math.pi}' upper='{math.pi}' effort='1' velocity='12'/>"),
])
def test_revolute_wheels_with_a_full_turn_of_range_count(jtype, extra):
    w = wheels_of(robot(wheel("l", 0.2, jtype=jtype, extra=extra),
                        wheel("r", -0.2, jtype=jtype, extra=extra)))
    assert w.separation == 0.4


def test_a_revolute_joint_that_cannot_turn_round_is_no_wheel_and_the_message_lists_it():
    extra = "<limit lower='-0.5' upper='0.5' effort='1' velocity='1'/>"
    text = robot(wheel("l", 0.2, jtype="revolute", extra=extra), wheel("r", -0.2))
    with pytest.raises(RobotDescriptionError) as info:
        wheels_of(text)
    message = str(info.value)
    assert message.startswith("r.urdf: no pair of drive wheels: expected two continuous")
    assert "'r_joint' (continuous, axis (+0.00, +1.00, +0.00) at (+0.000, -0.200" in message


@pytest.mark.parametrize("axis_left, axis_right", [("0 -1 0", "0 -1 0"), ("0 1 0", "0 -1 0")])
def test_wheel_axes_along_minus_y_are_wheels_too(axis_left, axis_right):
    w = wheels_of(robot(wheel("l", 0.1, axis=axis_left), wheel("r", -0.1, axis=axis_right)))
    assert w.separation == 0.2


def test_an_axis_given_in_a_frame_rolled_by_the_origin_rpy_is_composed_into_the_base():
    """The TurtleBot 3 way: the joint rolled by −1.57 rad, its axis z, its cylinder's axis the
    joint frame's z (no extra rotation)."""
    w = wheels_of(robot(wheel("l", 0.08, axis="0 0 1", rpy="-1.57 0 0", shape_rpy="0 0 0"),
                        wheel("r", -0.08, axis="0 0 1", rpy="-1.57 0 0", shape_rpy="0 0 0")))
    assert (w.radius, w.separation) == (0.05, 0.16)


def test_an_axis_about_x_is_no_wheel_axis_and_the_message_blames_the_base_frame():
    """Wheels at x = ±0.15 turning about x: the base drives along y (REP-103: x forward)."""
    text = robot(wheel("front", 0.0, x=0.15, axis="1 0 0", shape_rpy=f"0 {HALF_PI} 0"),
                 wheel("back", 0.0, x=-0.15, axis="1 0 0", shape_rpy=f"0 {HALF_PI} 0"))
    with pytest.raises(RobotDescriptionError, match=r"'front_joint', 'back_joint' turn about "
                       r"base_link's x axis and stand at x = -0\.150 and \+0\.150: this base "
                       r"drives along y, but REP-103 has x forward and y left — turn base_link "
                       r"by 90° about z"):
        wheels_of(text)


def test_wheels_under_a_suspension_joint_are_placed_by_the_composed_chain():
    """The TurtleBot 4 way: prismatic wheel drops rolled by −π/2, the wheels at their origin
    with axis z."""
    parts = []
    for side, y in (("left", 0.1165), ("right", -0.1165)):
        parts.append(link(f"drop_{side}") + joint(
            f"drop_{side}_joint", "prismatic", "base_link", f"drop_{side}", f"0 {y} 0.04",
            f"{-HALF_PI} 0 0", "0 1 0", "<limit lower='0' upper='0.03' effort='0' velocity='0'/>"))
        parts.append(wheel(f"{side}_wheel", 0.0, parent=f"drop_{side}", axis="0 0 1",
                           radius=0.03575, shape_rpy="0 0 0"))
    w = wheels_of(robot(*parts))
    assert (w.right, w.left, w.separation, w.radius) == ("right_wheel_joint", "left_wheel_joint",
                                                         0.233, 0.03575)
    np.testing.assert_allclose(w.left_position, [0.0, 0.1165, 0.04], atol=1e-12)


def test_casters_that_swivel_about_the_vertical_are_not_drive_wheels():
    """Four swivel casters at the corners, their wheels turning about y: only the two drive
    wheels count."""
    parts = [wheel("l", 0.2, radius=0.08), wheel("r", -0.2, radius=0.08)]
    for name, x, y in (("fl", 0.3, 0.15), ("fr", 0.3, -0.15), ("bl", -0.3, 0.15),
                       ("br", -0.3, -0.15)):
        parts.append(link(f"{name}_swivel") + joint(f"{name}_swivel_joint", "continuous",
                                                    "base_link", f"{name}_swivel",
                                                    f"{x} {y} -0.03", axis="0 0 1"))
        parts.append(wheel(f"{name}_caster", 0.0, x=-0.02, radius=0.02,
                           parent=f"{name}_swivel"))
    w = wheels_of(robot(*parts))
    assert (w.right, w.left, w.radius) == ("r_joint", "l_joint", 0.08)
    assert sum("swivels about the vertical: a caster" in n for n in w.notes) == 4


def test_a_caster_wheel_on_the_centre_line_is_not_a_drive_wheel():
    w = wheels_of(robot(wheel("l", 0.2), wheel("r", -0.2), wheel("caster", 0.0, x=-0.3)))
    assert (w.right, w.left) == ("r_joint", "l_joint")
    assert any("'caster_joint' is on the centre line" in n for n in w.notes)


def test_wheels_that_mimic_another_are_followers_not_drive_wheels():
    parts = [wheel("fl", 0.2, x=0.15), wheel("fr", -0.2, x=0.15),
             wheel("rl", 0.2, x=-0.15, extra="<mimic joint='fl_joint'/>"),
             wheel("rr", -0.2, x=-0.15, extra="<mimic joint='fr_joint'/>")]
    w = wheels_of(robot(*parts))
    assert (w.right, w.left) == ("fr_joint", "fl_joint")
    np.testing.assert_allclose(w.axle, [0.15, 0.0])


def test_four_independent_wheels_of_one_size_are_ambiguous_and_the_message_says_what_to_do():
    parts = [wheel("fl", 0.2, x=0.15), wheel("fr", -0.2, x=0.15), wheel("rl", 0.2, x=-0.15),
             wheel("rr", -0.2, x=-0.15)]
    with pytest.raises(RobotDescriptionError, match=r"cannot tell which wheels drive: 2 on the "
                       r"right and 2 on the left \('fr_joint' .*'rl_joint' .*\); the kit models "
                       r"a two-wheel differential drive: name the driven two in a parameter "
                       r"file \(\[wheels\] right_joint and left_joint\)"):
        wheels_of(robot(*parts))


def test_among_mirror_pairs_the_larger_wheels_drive_and_the_drive_plugin_decides_first():
    parts = [wheel("big_l", 0.2, radius=0.1), wheel("big_r", -0.2, radius=0.1),
             wheel("small_l", 0.15, x=-0.3, radius=0.03),
             wheel("small_r", -0.15, x=-0.3, radius=0.03)]
    w = wheels_of(robot(*parts))
    assert (w.right, w.radius) == ("big_r_joint", 0.1)
    plugin = ("<gazebo><plugin name='d' filename='libgazebo_ros_diff_drive.so'>"
              "<left_joint>small_l_joint</left_joint><right_joint>small_r_joint</right_joint>"
              "</plugin></gazebo>")
    w = wheels_of(robot(*parts, plugin))
    assert (w.right, w.radius) == ("small_r_joint", 0.03)


@pytest.mark.parametrize("root", ["base_footprint_root", "base_link_root"])
def test_base_footprint_or_base_link_at_the_root_gives_the_same_wheels(root):
    if root == "base_footprint_root":
        text = ("<robot name='r'><link name='base_footprint'/>"
                + link("base_link", "<box size='0.4 0.3 0.1'/>")
                + joint("fp", "fixed", "base_footprint", "base_link", "0 0 0.05")
                + wheel("l", 0.15) + wheel("r", -0.15) + "</robot>")
    else:
        text = robot(link("base_footprint"),
                     joint("fp", "fixed", "base_link", "base_footprint", "0 0 -0.05"),
                     wheel("l", 0.15), wheel("r", -0.15))
    model = urdf.parse(text, "r.urdf")
    assert robot_structure.base_frame(model) == "base_link"
    w = robot_structure.find_wheels(model, "base_link")
    assert (w.radius, w.separation) == (0.05, 0.3)


def test_a_base_off_the_axle_reports_where_the_wheels_midpoint_is():
    w = wheels_of(robot(wheel("l", 0.18, x=-0.12, radius=0.1), wheel("r", -0.18, x=-0.12,
                                                                    radius=0.1)))
    np.testing.assert_allclose(w.axle, [-0.12, 0.0])
    assert any("base_link is not on the axle" in n for n in w.notes)


@pytest.mark.parametrize("shape, shape_rpy, radius, word", [
    ("<sphere radius='0.04'/>", "0 0 0", 0.04, "collision sphere"),
    ("<box size='0.08 0.03 0.07'/>", "0 0 0", 0.035, "collision box's depth below the axle"),
    # a cylinder left standing up (no rotation): its half length is what reaches the ground
    ("<cylinder radius='0.05' length='0.06'/>", "0 0 0", 0.03, "lying across the axle"),
])
def test_the_radius_is_how_far_the_wheels_geometry_reaches_below_the_axle(shape, shape_rpy,
                                                                          radius, word):
    w = wheels_of(robot(wheel("l", 0.1, shape=shape, shape_rpy=shape_rpy),
                        wheel("r", -0.1, shape=shape, shape_rpy=shape_rpy)))
    assert w.radius == pytest.approx(radius, abs=1e-12)
    assert any(word in n for n in w.notes)


def test_a_wheel_with_visual_geometry_only_takes_its_radius_from_it():
    visual = link("l_link", "<cylinder radius='0.06' length='0.02'/>", rpy=f"{HALF_PI} 0 0",
                  kind="visual")
    text = robot(visual, joint("l_joint", "continuous", "base_link", "l_link", "0 0.1 0"),
                 wheel("r", -0.1, radius=0.06))
    w = wheels_of(text)
    assert w.radius == 0.06 and any("l_link's visual cylinder" in n for n in w.notes)


def test_a_tyre_fixed_to_the_wheel_link_gives_the_radius():
    tyre = (link("l_tyre", "<cylinder radius='0.07' length='0.02'/>", rpy=f"{HALF_PI} 0 0") +
            joint("l_tyre_joint", "fixed", "l_link", "l_tyre"))
    text = robot(link("l_link"), joint("l_joint", "continuous", "base_link", "l_link",
                                       "0 0.1 0"), tyre, wheel("r", -0.1, radius=0.07))
    w = wheels_of(text)
    assert w.radius == 0.07 and any("l_tyre's collision cylinder" in n for n in w.notes)


def test_a_wheel_without_geometry_is_an_error_naming_the_link_and_the_way_out():
    text = robot(link("l_link"), joint("l_joint", "continuous", "base_link", "l_link",
                                       "0 0.1 0"), wheel("r", -0.1))
    with pytest.raises(RobotDescriptionError, match=r"r\.urdf: wheel link 'l_link' \(joint "
                       r"'l_joint'\) has no collision or visual geometry .* \[wheels\] radius"):
        wheels_of(text)
    assert wheels_of(text, radius=0.07).radius == 0.07


def test_a_mesh_wheel_takes_its_radius_from_the_mesh_and_without_its_package_says_so(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    package = tmp_path / "my_robot_description"
    (package / "meshes").mkdir(parents=True)
    tyre = trimesh.creation.cylinder(radius=45.0, height=20.0, sections=64)   # millimetres
    tyre.export(package / "meshes" / "tyre.stl")
    mesh = "<mesh filename='package://my_robot_description/meshes/tyre.stl' scale='0.001 " \
           "0.001 0.001'/>"
    text = robot(wheel("l", 0.1, shape=mesh), wheel("r", -0.1, shape=mesh))
    path = tmp_path / "r.urdf"
    path.write_text(text)
    r = robots.load(path, package_paths={"my_robot_description": package})
    assert r.wheel_radius == pytest.approx(0.045, abs=1e-9)
    with pytest.raises(RobotDescriptionError, match=r"wheel link 'r_link' \(joint 'r_joint'\) "
                       r"has only meshes as collision geometry, and they cannot be read: "
                       r"package://my_robot_description/meshes/tyre\.stl: the ROS package "
                       r"'my_robot_description' is not found without ROS; say where its folder"
                       r" is with --package-path my_robot_description=DIR"):
        robots.load(path)


def test_the_footprint_is_the_hull_of_the_body_and_the_wheels():
    w_text = robot(wheel("l", 0.17, radius=0.05), wheel("r", -0.17, radius=0.05))
    model = urdf.parse(w_text, "r.urdf")
    w = robot_structure.find_wheels(model, "base_link")
    polygon, how = robot_structure.footprint(model, "base_link", w)
    # box 0.4 x 0.3 at the origin; wheels r = 0.05, 0.03 wide at y = ±0.17: out to ±0.185
    assert polygon[:, 0].min() == pytest.approx(-0.2) and polygon[:, 0].max() == pytest.approx(0.2)
    assert polygon[:, 1].min() == pytest.approx(-0.185)
    assert polygon[:, 1].max() == pytest.approx(0.185)
    assert "collision shapes of 1 links fixed to base_link and the two wheels" in how
    bare = urdf.parse(robot(wheel("l", 0.17), wheel("r", -0.17), base_shape=""), "r.urdf")
    polygon, how = robot_structure.footprint(bare, "base_link", w)
    assert how.startswith("assumed") and len(polygon) == 16
    np.testing.assert_allclose(np.hypot(*polygon.T), 0.17 + 0.05)


def test_the_lidar_is_the_gazebo_scanner_with_most_beams_else_the_link_named_so():
    parts = [wheel("l", 0.1), wheel("r", -0.1), link("cliff"), link("laser_frame"),
             link("top_scanner"),
             joint("c", "fixed", "base_link", "cliff", "0.1 0 0"),
             joint("lf", "fixed", "base_link", "laser_frame", "0.05 0 0.2", "0 0 3.14159"),
             joint("ts", "fixed", "base_link", "top_scanner", "-0.1 0.02 0.3", f"0 0 {HALF_PI}"),
             "<gazebo reference='cliff'><sensor type='gpu_lidar' name='cliff'><lidar><scan>"
             "<horizontal><samples>1</samples><min_angle>0</min_angle><max_angle>0</max_angle>"
             "</horizontal></scan></lidar></sensor></gazebo>"]
    scanner = ("<gazebo reference='top_scanner'><sensor type='ray' name='s'><ray><scan>"
               "<horizontal><samples>720</samples><min_angle>-3.14</min_angle>"
               "<max_angle>3.14</max_angle></horizontal></scan></ray></sensor></gazebo>")
    model = urdf.parse(robot(*parts, scanner), "r.urdf")
    mount = robot_structure.find_lidar(model, "base_link")
    assert mount is not None and mount.frame == "top_scanner"
    assert mount.pose == pytest.approx((-0.1, 0.02, HALF_PI))
    model = urdf.parse(robot(*parts), "r.urdf")
    mount = robot_structure.find_lidar(model, "base_link")
    assert mount is not None and (mount.frame, mount.how) == ("laser_frame", "its link's name")
    assert mount.pose[2] == pytest.approx(3.14159)
    assert robot_structure.find_lidar(urdf.parse(robot(wheel("l", 0.1), wheel("r", -0.1)),
                                                 "r.urdf"), "base_link") is None


def test_named_wheels_are_checked_against_rep103_in_the_composed_frame():
    text = robot(wheel("right_wheel", 0.1), wheel("left_wheel", -0.1))
    model = urdf.parse(text, "r.urdf")
    with pytest.raises(RobotDescriptionError, match=r"REP-103: y points left\); in base_link, "
                       r"composed from the root, the right wheel 'right_wheel_joint' is at "
                       r"y=0\.1"):
        robot_structure.named_wheels(model, "base_link", "right_wheel_joint", "left_wheel_joint")


def test_a_ray_sensor_pointing_down_is_a_cliff_sensor_not_the_lidar():
    """The Kobuki's cliff sensors are 50-beam Gazebo rays pitched down by π/2."""
    cliff = (link("cliff_left") + joint("cl", "fixed", "base_link", "cliff_left", "0.09 0.14 0.02",
                                        f"0 {HALF_PI} 0") +
             "<gazebo reference='cliff_left'><sensor type='ray' name='cliff_left'><ray><scan>"
             "<horizontal><samples>50</samples><min_angle>-0.01</min_angle><max_angle>0.01"
             "</max_angle></horizontal></scan></ray></sensor></gazebo>")
    model = urdf.parse(robot(wheel("l", 0.1), wheel("r", -0.1), cliff), "r.urdf")
    assert robot_structure.find_lidar(model, "base_link") is None


def test_a_mimic_only_drive_is_refused_with_the_reason_for_each_joint():
    """A car-like robot: its rear wheels follow a virtual centre wheel."""
    parts = [wheel("virtual", 0.0, x=-0.16), wheel("rl", 0.13, x=-0.16,
                                                     extra="<mimic joint='virtual_joint'/>"),
             wheel("rr", -0.13, x=-0.16, extra="<mimic joint='virtual_joint'/>")]
    with pytest.raises(RobotDescriptionError, match=r"left out: 'virtual_joint' is on the centre "
                       r"line \(y = 0\): not a drive wheel; 'rl_joint' mimics 'virtual_joint'"):
        wheels_of(robot(*parts))


def test_links_that_no_joint_joins_to_the_base_are_named():
    text = ("<robot name='r'>" + link("base_link") + link("other") +
            wheel("l", 0.1) + wheel("r", -0.1, parent="other") + "</robot>")
    with pytest.raises(RobotDescriptionError, match=r"no joints join 'r_link' to 'base_link': "
                       r"they hang from different roots \('other', 'base_link'\)"):
        wheels_of(text)


def test_default_speed_limits_never_exceed_what_the_wheel_joints_limits_allow(tmp_path):
    extra = "<limit effort='1' velocity='2.0'/>"
    path = tmp_path / "slow.urdf"
    path.write_text(robot(wheel("l", 0.1, radius=0.05, extra=extra),
                          wheel("r", -0.1, radius=0.05, extra=extra)))
    r = robots.load(path)
    assert r.max_wheel_speed == 2.0 and r.max_linear_velocity == pytest.approx(0.1)
    assert r.max_angular_velocity == pytest.approx(1.0)        # 2 r ω / b = 2*0.05*2/0.2
    assert "max_linear_velocity 0.1: the wheels' top speed (2 rad/s) allows no more than the " \
           "default" in r.assumed
    assert not any(a.startswith("max_linear_velocity 0.26") for a in r.assumed)


AXES = {  # (axis, joint rpy, cylinder rpy): four ways URDFs write a wheel turning about y
    "y": ("0 1 0", "0 0 0", f"{HALF_PI} 0 0"),
    "-y": ("0 -1 0", "0 0 0", f"{HALF_PI} 0 0"),
    "z rolled -pi/2": ("0 0 1", f"{-HALF_PI} 0 0", "0 0 0"),
    "-z rolled +pi/2": ("0 0 -1", f"{HALF_PI} 0 0", "0 0 0"),
}


@settings(max_examples=40, deadline=None)
@given(separation=st.floats(0.1, 1.2), radius=st.floats(0.02, 0.3), axle_x=st.floats(-0.4, 0.4),
       left_axis=st.sampled_from(sorted(AXES)), right_axis=st.sampled_from(sorted(AXES)),
       footprint_root=st.booleans(), suspension=st.booleans(), casters=st.integers(0, 4),
       followers=st.booleans())
def test_any_differential_drive_written_any_usual_way_gives_back_its_geometry(
        separation, radius, axle_x, left_axis, right_axis, footprint_root, suspension, casters,
        followers):
    """A generated robot — its wheels' axes written four ways, base_footprint or base_link at
    the root, wheels on prismatic suspensions or not, swivel casters, mimic followers — gives
    back the radius, separation and axle it was built with."""
    parts = []
    for side, y, axis_key in (("left", separation / 2, left_axis),
                              ("right", -separation / 2, right_axis)):
        axis, rpy, shape_rpy = AXES[axis_key]
        parent = "base_link"
        if suspension:
            parts.append(link(f"drop_{side}") + joint(
                f"drop_{side}_joint", "prismatic", "base_link", f"drop_{side}",
                f"{axle_x} {y} 0.02", axis="0 0 1",
                extra="<limit lower='-0.02' upper='0.02' effort='1' velocity='1'/>"))
            parent, x, y_local = f"drop_{side}", 0.0, 0.0
        else:
            x, y_local = axle_x, y
        parts.append(wheel(f"{side}_drive", y_local, x=x, radius=radius, parent=parent,
                           axis=axis, rpy=rpy, shape_rpy=shape_rpy))
        if followers:
            parts.append(wheel(f"{side}_follower", y, x=axle_x + 0.5, radius=radius,
                               extra=f"<mimic joint='{side}_drive_joint'/>"))
    for i in range(casters):
        cx, cy = (0.5 if i % 2 else -0.5), (0.2 if i < 2 else -0.2)
        parts.append(link(f"swivel{i}") + joint(f"swivel{i}_joint", "continuous", "base_link",
                                                f"swivel{i}", f"{cx} {cy} -0.05", axis="0 0 1"))
        parts.append(wheel(f"caster{i}", 0.0, x=-0.02, radius=0.02, parent=f"swivel{i}"))
    if footprint_root:
        text = ("<robot name='r'><link name='base_footprint'/>" +
                link("base_link", "<box size='0.4 0.3 0.1'/>") +
                joint("fp", "fixed", "base_footprint", "base_link", f"0 0 {radius}") +
                "".join(parts) + "</robot>")
    else:
        text = robot(*parts)
    model = urdf.parse(text, "generated.urdf")
    assert robot_structure.base_frame(model) == "base_link"
    w = robot_structure.find_wheels(model, "base_link")
    assert (w.right, w.left) == ("right_drive_joint", "left_drive_joint")
    assert w.radius == pytest.approx(radius, abs=1e-9)
    assert w.separation == pytest.approx(separation, abs=1e-9)
    assert w.axle == pytest.approx([axle_x, 0.0], abs=1e-9)
