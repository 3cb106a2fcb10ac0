"""Bad map_server maps get a MapError naming the file and what is wrong."""

import pytest

from kit import maps

KEYS = "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
"""The keys map_server needs besides image, resolution and origin."""
PLAIN = "resolution: 0.1\norigin: [0, 0, 0]\n" + KEYS


@pytest.mark.parametrize(("pgm", "yaml", "message"), [
    (b"P5\n10 10\n", "resolution: 0.1\norigin: [0, 0, 0]",
     r"m\.pgm: truncated PGM header: 2 of the 3 numbers"),
    (b"P5\n0 10\n255\n", "resolution: 0.1\norigin: [0, 0, 0]",
     r"m\.pgm: the image has no pixels \(0 x 10\)"),
    (b"P2\n3 2\n255\n0 0 0 0\n", "resolution: 0.1\norigin: [0, 0, 0]",
     r"m\.pgm: truncated: 4 of 6 pixels"),
    (b"P5\n2 2\n255\n\0\0\0\0", "resolution: fine\norigin: [0, 0, 0]",
     r"m\.yaml: resolution, occupied_thresh and free_thresh must be numbers"),
    (b"P5\n2 2\n255\n\0\0\0\0", "resolution: 0.1\norigin: 5",
     r"m\.yaml: .*origin a list \[x, y, yaw\]"),
])
def test_bad_maps_name_the_file_and_the_problem(tmp_path, pgm, yaml, message):
    (tmp_path / "m.pgm").write_bytes(pgm)
    (tmp_path / "m.yaml").write_text(f"image: m.pgm\n{yaml}\n" + KEYS)
    with pytest.raises(maps.MapError, match=message):
        maps.read_map(tmp_path / "m.yaml")


def test_a_yaml_naming_a_missing_image_says_which(tmp_path):
    (tmp_path / "m.yaml").write_text("image: gone.pgm\n" + PLAIN)
    with pytest.raises(maps.MapError, match=r"its image .*gone\.pgm does not exist"):
        maps.read_map(tmp_path / "m.yaml")


@pytest.mark.parametrize(("drop", "message"), [
    ("negate", r"m\.yaml: missing 'negate' \(map_server needs image, resolution, origin, negate, "
               r"occupied_thresh, free_thresh; mode is optional"),
    ("free_thresh", r"m\.yaml: missing 'free_thresh'"),
    ("occupied_thresh", r"m\.yaml: missing 'occupied_thresh'"),
])
def test_a_yaml_map_server_refuses_is_refused_with_the_missing_key(tmp_path, drop, message):
    """Nav2's map_server (map_io.cpp, loadMapYaml) throws without negate or the thresholds;
    so does the kit, rather than read a map Nav2 will not load."""
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 2\n255\n\0\0\0\0")
    lines = [line for line in PLAIN.splitlines() if not line.startswith(drop + ":")]
    (tmp_path / "m.yaml").write_text("image: m.pgm\n" + "\n".join(lines) + "\n")
    with pytest.raises(maps.MapError, match=message):
        maps.read_map(tmp_path / "m.yaml")


@pytest.mark.parametrize(("negate", "pixel"), [("0", 100), ("1", 0), ("true", 0),
                                               ("false", 100)])
def test_negate_is_an_integer_or_a_boolean_as_map_server_reads_it(tmp_path, negate, pixel):
    (tmp_path / "m.pgm").write_bytes(b"P5\n1 1\n255\n\0")       # black: occupied unless negated
    (tmp_path / "m.yaml").write_text(
        "image: m.pgm\n" + PLAIN.replace("negate: 0", f"negate: {negate}"))
    assert maps.read_map(tmp_path / "m.yaml").data.tolist() == [pixel]


def test_a_fractional_negate_is_refused(tmp_path):
    (tmp_path / "m.pgm").write_bytes(b"P5\n1 1\n255\n\0")
    (tmp_path / "m.yaml").write_text("image: m.pgm\n" + PLAIN.replace("negate: 0", "negate: 0.5"))
    with pytest.raises(maps.MapError, match="negate 0 or 1"):
        maps.read_map(tmp_path / "m.yaml")


def test_a_map_path_starting_with_a_tilde_is_the_home_directory(tmp_path, monkeypatch):
    """As Nav2's map_server expands ``~/`` in the map YAML's path."""
    monkeypatch.setenv("HOME", str(tmp_path))
    (tmp_path / "m.pgm").write_bytes(b"P5\n1 1\n255\n\xfe")
    (tmp_path / "m.yaml").write_text("image: m.pgm\n" + PLAIN)
    assert maps.read_map("~/m.yaml").data.tolist() == [0]
