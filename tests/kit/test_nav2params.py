"""Nav2 parameter files read as ROS 2 reads them: node names, namespaces and wildcards,
nested mappings flattened to dotted names, YAML anchors, values given as strings, and every
bad input named in a ValueError."""

from __future__ import annotations

import pytest

from kit.nav2params import Nav2File, ParameterReport, Section, flatten


def write(tmp_path, text, name="p.yaml"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_nested_mappings_become_ros2s_dotted_names():
    assert flatten({"FollowPath": {"plugin": "x", "BaseObstacle.scale": 0.02,
                                   "scan": {"topic": "/scan"}}, "plugins": ["a", "b"]}) == {
        "FollowPath.plugin": "x", "FollowPath.BaseObstacle.scale": 0.02,
        "FollowPath.scan.topic": "/scan", "plugins": ["a", "b"]}


NAMESPACED = """\
/**:
  ros__parameters:
    use_sim_time: true
robot1:
  amcl:
    ros__parameters:
      max_particles: 1000
  local_costmap:
    local_costmap:
      ros__parameters:
        resolution: 0.05
/robot2/amcl:
  ros__parameters:
    max_particles: 3000
/robot2/local_costmap/local_costmap:
  ros__parameters:
    resolution: 0.1
/**/amcl:
  ros__parameters:
    min_particles: 200
"""


def test_a_node_takes_the_wildcards_and_its_namespace_in_file_order(tmp_path):
    f = Nav2File(write(tmp_path, NAMESPACED), namespace="robot2")
    name, params, origin = f.node("amcl")
    assert name == "amcl"
    assert params == {"use_sim_time": True, "max_particles": 3000, "min_particles": 200}
    assert origin == {"use_sim_time": "**", "max_particles": "robot2/amcl",
                      "min_particles": "**/amcl"}
    _, costmap, _ = f.node("local_costmap/local_costmap")
    assert costmap["resolution"] == 0.1
    robot1 = Nav2File(write(tmp_path, NAMESPACED), namespace="/robot1")
    assert robot1.node("amcl")[1]["max_particles"] == 1000


def test_a_node_under_several_namespaces_needs_one_named(tmp_path):
    f = Nav2File(write(tmp_path, NAMESPACED))
    with pytest.raises(ValueError, match=r"amcl is configured under several namespaces "
                                         r"\(/robot1, /robot2\): name the robot's namespace"):
        f.node("amcl")
    assert f.namespaces("amcl") == [("robot1",), ("robot2",)]


def test_one_namespace_is_found_by_itself_and_the_placeholder_is_replaced(tmp_path):
    text = ("tb3:\n  local_costmap:\n    local_costmap:\n      ros__parameters:\n"
            "        voxel_layer:\n          scan:\n            topic: <robot_namespace>/scan\n")
    f = Nav2File(write(tmp_path, text))
    _, params, origin = f.node("local_costmap/local_costmap")
    assert params == {"voxel_layer.scan.topic": "/scan"}      # no namespace given: removed
    assert origin["voxel_layer.scan.topic"] == "tb3/local_costmap/local_costmap"
    named = Nav2File(write(tmp_path, text), namespace="tb3")
    assert named.node("local_costmap/local_costmap")[1] == {"voxel_layer.scan.topic":
                                                            "/tb3/scan"}
    assert any("<robot_namespace>" in note for note in named.notes)


def test_anchors_and_merge_keys_are_resolved(tmp_path):
    text = """\
scan_source: &scan
  topic: /scan
  marking: true
  clearing: true
local_costmap:
  local_costmap:
    ros__parameters:
      voxel_layer:
        scan:
          <<: *scan
          obstacle_max_range: 2.0
      obstacle_layer:
        scan: *scan
"""
    f = Nav2File(write(tmp_path, text))
    _, params, _ = f.node("local_costmap/local_costmap")
    assert params == {"voxel_layer.scan.topic": "/scan", "voxel_layer.scan.marking": True,
                      "voxel_layer.scan.clearing": True,
                      "voxel_layer.scan.obstacle_max_range": 2.0,
                      "obstacle_layer.scan.topic": "/scan", "obstacle_layer.scan.marking": True,
                      "obstacle_layer.scan.clearing": True}
    report = f.report()
    assert report.ignored == {"scan_source/topic:": "not under ros__parameters: ROS 2 does "
                                                    "not read it",
                              "scan_source/marking:": "not under ros__parameters: ROS 2 does "
                                                      "not read it",
                              "scan_source/clearing:": "not under ros__parameters: ROS 2 "
                                                       "does not read it"}


def test_a_repeated_key_is_noted_and_the_file_still_loads(tmp_path):
    f = Nav2File(write(tmp_path, "amcl:\n  ros__parameters:\n    alpha1: 0.1\n    alpha1: 0.3\n"))
    assert f.node("amcl")[1] == {"alpha1": 0.1}
    assert any("appears twice" in note for note in f.notes)


@pytest.mark.parametrize(("text", "message"), [
    ("amcl: [unclosed\n", "not valid YAML"),
    ("- a\n- b\n", "a YAML mapping of node names; got list"),
    ("amcl:\n  alpha1: 0.2\n", "no node with ros__parameters in it .top-level keys: amcl"),
    ("amcl:\n  ros__parameters: 3\n", "amcl.ros__parameters must be a mapping"),
])
def test_files_that_are_not_parameter_files_are_named(tmp_path, text, message):
    with pytest.raises(ValueError, match=message):
        Nav2File(write(tmp_path, text))


def test_a_missing_file_or_a_folder_or_binary_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="no such parameter file"):
        Nav2File(tmp_path / "nope.yaml")
    with pytest.raises(ValueError, match="a directory"):
        Nav2File(tmp_path)
    (tmp_path / "b.yaml").write_bytes(b"\xff\xfe\x00amcl")
    with pytest.raises(ValueError, match="not a text file"):
        Nav2File(tmp_path / "b.yaml")


def test_values_given_as_strings_are_read_and_noted():
    report = ParameterReport(keys=["n:a", "n:b", "n:c", "n:d", "n:e"])
    s = Section(report, "n", {"a": "0.26", "b": "true", "c": "Off", "d": 3, "e": 20.0})
    assert s.get("a", 0.5) == 0.26 and s.get("b", False) is True and s.get("c", True) is False
    assert s.get("d", 1.0) == 3.0 and isinstance(s.get("d", 1.0), float)
    assert s.get("e", 1) == 20 and isinstance(s.get("e", 1), int)
    assert set(report.used) == {"n:a", "n:b", "n:c", "n:d", "n:e"}
    assert any("n.a is given as the string '0.26': read as 0.26" in n for n in report.notes)
    assert any("n.e is an integer parameter given as 20.0" in n for n in report.notes)
    assert report.errors == []


def test_values_that_do_not_read_are_collected_and_named():
    report = ParameterReport("f.yaml")
    s = Section(report, "controller_server", {"FollowPath.max_vel_x": "fast",
                                              "FollowPath.vx_samples": 2.5,
                                              "FollowPath.debug": "$(var debug)"},
                prefix="FollowPath")
    assert s.get("max_vel_x", 0.5) == 0.5 and s.get("vx_samples", 20) == 20
    assert s.get("debug", False) is False
    with pytest.raises(ValueError) as info:
        report.raise_errors()
    message = str(info.value)
    assert message.startswith("f.yaml: controller_server.FollowPath.max_vel_x must be a number; "
                              "got 'fast'")
    assert "FollowPath.vx_samples must be an integer; got 2.5" in message
    assert "FollowPath.debug must be true or false; got '$(var debug)' (a launch-file " \
           "substitution left in the file?)" in message


def test_lists_of_names_read_as_nav2_reads_them():
    report = ParameterReport()
    s = Section(report, "n", {"a": "scan bump", "b": "[x, 'y']", "c": ["p", "q"], "d": None,
                              "e": [["x"]]})
    assert s.get_list("a", []) == ["scan", "bump"]
    assert s.get_list("b", []) == ["x", "y"]
    assert s.get_list("c", []) == ["p", "q"]
    assert s.get_list("d", ["z"]) == []
    assert s.get_list("e", ["z"]) == ["z"] and "n.e must be a list of names" in report.errors[0]


def test_the_report_names_each_unused_key_once_grouped_by_node_and_reason():
    report = ParameterReport("f.yaml", keys=["amcl:alpha1", "amcl:scan_topic",
                                             "amcl:tf_broadcast", "map_server:yaml_filename"])
    report.use("amcl:alpha1", "0.2")
    report.ignore("amcl:scan_topic", "no effect")
    report.ignore("amcl:scan_topic", "a second reason is not taken")
    report.ignore("amcl:tf_broadcast", "no effect")
    report.ignore("map_server:yaml_filename", "not mirrored")
    report.keep("amcl:deskew", "true")
    text = "\n".join(report.lines())
    assert report.unaccounted() == []
    assert text.count("scan_topic") == 1 and "second reason" not in text
    assert "amcl — no effect: scan_topic, tf_broadcast" in text
    assert "map_server — not mirrored: yaml_filename" in text
    assert report.summary() == "1 keys used, 3 not used, 1 kit values kept"
