from pathlib import Path

import numpy as np
import pytest

from kit import geometry, maps, msgs

KEYS = "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
"""The keys map_server needs besides image, resolution and origin."""
PLAIN = "resolution: 0.1\norigin: [0, 0, 0]\n" + KEYS

NAV2_TESTMAP_ROWS = [  # nav2_map_server/test/test_constants.cpp, bottom row first
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    [100, 100, 100, 100, 0, 0, 100, 100, 100, 0],
    [100, 100, 100, 100, 0, 0, 100, 100, 100, 0],
    [100, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    [100, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 100, 100, 0, 0],
    [100, 0, 0, 0, 0, 0, 0, 0, 0, 0],
]


@pytest.mark.dataset
@pytest.mark.parametrize("image", ["testmap.png", "testmap.pgm", "testmap.bmp"])
def test_nav2_testmap_gives_nav2s_golden_grid(shared_data, tmp_path, image):
    folder = shared_data / "maps" / "nav2-map-server-testmap"
    yaml = (folder / "testmap.yaml").read_text().replace('"testmap.png"', f'"{folder / image}"')
    (tmp_path / "m.yaml").write_text(yaml)
    grid = maps.read_map(tmp_path / "m.yaml")
    assert (grid.info.width, grid.info.height) == (10, 10)
    assert grid.info.resolution == pytest.approx(0.1)
    o = grid.info.origin
    assert (o.position.x, o.position.y) == (2.0, 3.0)
    yaw = geometry.quaternion_to_yaw([o.orientation.x, o.orientation.y, o.orientation.z,
                                      o.orientation.w])
    assert float(yaw) == pytest.approx(1.0)
    np.testing.assert_array_equal(grid.data.reshape(10, 10), NAV2_TESTMAP_ROWS)


@pytest.mark.dataset
@pytest.mark.parametrize(("folder", "name", "counts"), [
    ("turtlebot3-world-nav2", "map.yaml", (795, 7939, 138722)),
    ("olin-mac-first-floor-real", "mac_1st_floor_final.yaml", (16871, 1523647, 0)),
    ("turtlebot3-house-slam-toolbox-png", "map8.yaml", (2979, 59899, 0)),
])
def test_real_maps_follow_map_server_exactly(shared_data, folder, name, counts):
    grid = maps.read_map(shared_data / "maps" / folder / name)
    occupied, free, unknown = (int(np.sum(grid.data == v)) for v in (100, 0, -1))
    assert (occupied, free, unknown) == counts


def test_write_then_read_round_trips(tmp_path):
    rng = np.random.default_rng(0)
    data = rng.choice(np.array([-1, 0, 100], dtype=np.int8), 12 * 7)
    info = msgs.MapMetaData(resolution=0.05, width=12, height=7,
                            origin=msgs.Pose(msgs.Point(-1.5, 2.25, 0.0)))
    grid = msgs.OccupancyGrid(msgs.Header(frame_id="map"), info, data)
    maps.write_map(grid, tmp_path / "saved.yaml")
    back = maps.read_map(tmp_path / "saved.yaml")
    assert back.info == grid.info
    np.testing.assert_array_equal(back.data, grid.data)


def _map_saver_pixel(cell: int, free_thresh: float, occupied_thresh: float) -> int:
    """Nav2's map_saver (nav2_map_server/src/map_io.cpp, trinary mode), cell by cell."""
    free_int, occupied_int = round(free_thresh * 100.0), round(occupied_thresh * 100.0)
    if cell < 0 or 100 < cell:
        return 205
    if cell <= free_int:
        return 254
    if occupied_int <= cell:
        return 0
    return 205


@pytest.mark.parametrize("free_thresh, occupied_thresh", [
    (maps.FREE_THRESH, maps.OCCUPIED_THRESH), (0.25, 0.65), (0.3, 0.7), (0.125, 0.625),
    (0.5, 0.51), (0.0, 1.0)])
def test_write_map_classes_every_cell_value_by_the_thresholds_it_is_given(
        tmp_path, free_thresh, occupied_thresh):
    """Every int8 value, as map_saver writes it with those thresholds (0.125 and 0.625: the
    halves round to even, as C's rint does); the YAML carries map_saver's fixed thresholds,
    so the map reads back as the three greys say, whatever thresholds wrote it."""
    data = np.arange(-128, 128, dtype=np.int8)
    info = msgs.MapMetaData(resolution=0.1, width=16, height=16)
    pgm = maps.write_map(msgs.OccupancyGrid(msgs.Header(frame_id="map"), info, data),
                         tmp_path / "m.yaml", free_thresh, occupied_thresh)
    pixels = np.flipud(maps.read_pgm(pgm)).ravel()
    expected = [_map_saver_pixel(int(v), free_thresh, occupied_thresh) for v in data]
    assert pixels.tolist() == expected
    yaml = (tmp_path / "m.yaml").read_text()
    assert "occupied_thresh: 0.65\n" in yaml and "free_thresh: 0.196\n" in yaml
    back = maps.read_map(tmp_path / "m.yaml").data
    as_written = {254: 0, 0: 100, 205: -1}
    assert back.tolist() == [as_written[p] for p in expected]


def test_write_map_refuses_thresholds_out_of_order(tmp_path):
    grid = msgs.OccupancyGrid(msgs.Header(frame_id="map"),
                              msgs.MapMetaData(resolution=0.1, width=2, height=1),
                              np.zeros(2, dtype=np.int8))
    with pytest.raises(ValueError, match="free_thresh must be below occupied_thresh"):
        maps.write_map(grid, tmp_path / "m.yaml", 0.7, 0.3)
    with pytest.raises(ValueError, match="free_thresh must be below occupied_thresh"):
        maps.write_map(grid, tmp_path / "m.yaml", 0.5, 0.5)
    with pytest.raises(ValueError, match=r"0 <= free_thresh <= occupied_thresh <= 1"):
        maps.write_map(grid, tmp_path / "m.yaml", 0.2, 1.5)
    assert not (tmp_path / "m.pgm").exists() and not (tmp_path / "m.yaml").exists()


def test_truncated_and_malformed_maps_name_the_file(tmp_path):
    (tmp_path / "m.pgm").write_bytes(b"P5\n4 4\n255\n" + bytes(10))
    (tmp_path / "m.yaml").write_text("image: m.pgm\n" + PLAIN)
    with pytest.raises(maps.MapError, match=r"m\.pgm: truncated: 10 bytes"):
        maps.read_map(tmp_path / "m.yaml")
    (tmp_path / "n.yaml").write_text("image: m.pgm\norigin: [0, 0, 0]\n" + KEYS)
    with pytest.raises(maps.MapError, match=r"n\.yaml: missing 'resolution'"):
        maps.read_map(tmp_path / "n.yaml")
    (tmp_path / "o.yaml").write_text("image: nothere.pgm\n" + PLAIN)
    with pytest.raises(maps.MapError, match="does not exist"):
        maps.read_map(tmp_path / "o.yaml")
    (tmp_path / "p.yaml").write_text("image: [unclosed\n")
    with pytest.raises(maps.MapError, match="not valid YAML"):
        maps.read_map(tmp_path / "p.yaml")
    (tmp_path / "q.pgm").write_bytes(b"GIF89a")
    (tmp_path / "q.yaml").write_text("image: q.pgm\n" + PLAIN)
    with pytest.raises(maps.MapError, match="not a PGM"):
        maps.read_map(tmp_path / "q.yaml")


@pytest.mark.parametrize(("line", "message"), [
    ("resolution: -0.05\norigin: [0, 0, 0]",
     r"r\.yaml: resolution must be a positive number of metres per cell; got -0\.05"),
    ("resolution: .nan\norigin: [0, 0, 0]", r"resolution must be a positive number .* got nan"),
    ("resolution: 0.05\norigin: [1.5, 2]",
     r"r\.yaml: origin must be \[x, y, yaw\] .* got \[1\.5, 2\]"),
    ("resolution: 0.05\norigin: [0, .inf, 0]", r"origin must be \[x, y, yaw\]"),
])
def test_a_bad_resolution_and_a_bad_origin_get_their_own_messages(tmp_path, line, message):
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 2\n255\n" + bytes(4))
    (tmp_path / "r.yaml").write_text(f"image: m.pgm\n{line}\n" + KEYS)
    with pytest.raises(maps.MapError, match=message):
        maps.read_map(tmp_path / "r.yaml")


MAP_IMAGES = Path(__file__).parent / "data" / "map_images"
"""Images of every kind a map can come as, and what Nav2's map_server makes of each
(``reference.npz``: GraphicsMagick and Eigen computed it, see that folder's README)."""


def _reference() -> dict[str, np.ndarray]:
    with np.load(MAP_IMAGES / "reference.npz") as npz:
        return {key: npz[key] for key in npz.files}


@pytest.mark.parametrize("image", sorted(p.name for p in MAP_IMAGES.iterdir()
                                         if p.suffix in (".pgm", ".png", ".bmp")))
def test_every_kind_of_image_reads_as_map_server_reads_it(tmp_path, image):
    """Each image's greys and alpha are GraphicsMagick's (colour by Rec. 601 luma, 16-bit by
    its top byte, a palette's or grey's transparent entry as alpha), and its cells in every
    mode, for both values of ``negate`` and six threshold pairs, are map_server's, cell for
    cell, through ``read_map`` as a user calls it."""
    reference = _reference()
    grey, alpha = maps.read_image(MAP_IMAGES / image)
    np.testing.assert_array_equal(grey, reference[f"{image}|grey"])
    if f"{image}|alpha" in reference:
        assert alpha is not None, "map_server sees an alpha channel"
        np.testing.assert_array_equal(alpha, reference[f"{image}|alpha"])
    else:
        assert alpha is None
    cases = [key for key in reference if key.startswith(f"{image}|")
             and key.split("|")[1] in ("trinary", "scale", "raw")]
    assert len(cases) == 25
    for key in cases:
        _, mode, *rest = key.split("|")
        negate, free, occupied = (rest[0], rest[1], rest[2]) if rest else ("0", "0.196", "0.65")
        (tmp_path / "m.yaml").write_text(
            f"image: {MAP_IMAGES / image}\nmode: {mode}\nresolution: 0.05\norigin: [0, 0, 0]\n"
            f"negate: {negate}\nfree_thresh: {free}\noccupied_thresh: {occupied}\n")
        grid = maps.read_map(tmp_path / "m.yaml")
        cells = np.flipud(grid.data.reshape(grid.info.height, grid.info.width))
        np.testing.assert_array_equal(cells, reference[key], err_msg=key)


def test_raw_mode_keeps_0_to_100_and_makes_the_rest_unknown():
    """Nav2's raw mode: a grey 0…100 is the cell, anything above is −1 (never a wrapped int8)."""
    grey = np.arange(256, dtype=np.uint8).reshape(16, 16)
    cells = maps.cells_of(grey, None, "raw")
    assert cells.dtype == np.int8
    np.testing.assert_array_equal(cells.ravel()[:101], np.arange(101))
    assert (cells.ravel()[101:] == -1).all()


def test_a_pgm_pixel_above_its_maxval_is_refused(tmp_path):
    (tmp_path / "m.pgm").write_bytes(b"P5\n2 1\n100\n" + bytes([50, 200]))
    (tmp_path / "m.yaml").write_text("image: m.pgm\n" + PLAIN)
    with pytest.raises(maps.MapError, match=r"m\.pgm: a pixel is above the header's maxval 100"):
        maps.read_map(tmp_path / "m.yaml")


def test_a_damaged_png_names_the_file(tmp_path):
    good = (MAP_IMAGES / "colour.png").read_bytes()
    (tmp_path / "m.png").write_bytes(good[: len(good) // 2])
    (tmp_path / "m.yaml").write_text("image: m.png\n" + PLAIN)
    with pytest.raises(maps.MapError, match=r"m\.png: unreadable image"):
        maps.read_map(tmp_path / "m.yaml")
