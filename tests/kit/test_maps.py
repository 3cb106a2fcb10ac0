"""Bad map_server maps get a MapError naming the file and what is wrong."""

import pytest

from kit import maps


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
    (tmp_path / "m.yaml").write_text(f"image: m.pgm\n{yaml}\n")
    with pytest.raises(maps.MapError, match=message):
        maps.read_map(tmp_path / "m.yaml")


def test_a_yaml_naming_a_missing_image_says_which(tmp_path):
    (tmp_path / "m.yaml").write_text("image: gone.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(maps.MapError, match=r"its image .*gone\.pgm does not exist"):
        maps.read_map(tmp_path / "m.yaml")
