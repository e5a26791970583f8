"""Cable centreline extraction, deprojection and registration on synthetic rendered images.

The cable is drawn through the known camera (tests/_vision_scene.py) along a sine-shaped
centreline; after calibration from the markers in the same image, the registered shape must
match the drawn centreline within 1 mm (mean point error and largest distance to the curve).
A pixel is about 1 mm on the table here, so this asks for sub-pixel centrelines.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from _vision_scene import (
    CABLE_BGR,
    CAMERA_TO_ROBOT,
    INTRINSICS,
    MARKER_LENGTH,
    MARKER_POSES,
    SECOND_BGR,
    plane_maps,
    render,
    sine_cable,
)

from dloplan.geometry import resample_by_arc_length
from dloplan.vision import (
    CentrelineError,
    HsvRange,
    MarkerLayout,
    calibrate_extrinsics,
    compare_shapes,
    deproject_depth,
    deproject_to_plane,
    depth_at_pixels,
    extract_centreline,
    invert_pose,
    register_on_plane,
    register_with_depth,
    transform_points,
)

# its module-scoped fixtures are computed once, on one worker (make test: --dist loadgroup)
pytestmark = pytest.mark.xdist_group("test_vision_registration")

BLUE = HsvRange((95, 120, 60), (120, 255, 255))
RED = HsvRange((170, 120, 60), (10, 255, 255))  # wraps around hue 180
N_POINTS = 21


def distance_to_curve(points, curve):
    """Distance [m] of each point to a dense polyline (x-y), (k,)."""
    a, b = curve[:-1, :2], curve[1:, :2]
    ab = b - a
    p = points[:, None, :2]
    t = np.clip(np.einsum("kij,ij->ki", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1).min(axis=1)


@pytest.fixture(scope="module", params=[(0.3, 0.05, 0.006), (1.9, 0.03, 0.01), (-1.2, 0.08, 0.004)],
                ids=["sine-6mm", "gentle-10mm", "deep-4mm"])
def scene(request):
    yaw, amplitude, diameter = request.param
    cable = sine_cable(yaw=yaw, amplitude=amplitude)
    image = render([(cable, diameter, CABLE_BGR)])
    calibration = calibrate_extrinsics(image, INTRINSICS, MarkerLayout(MARKER_LENGTH,
                                                                       MARKER_POSES))
    return cable, diameter, image, calibration


def test_registered_shape_matches_the_drawn_cable(scene):
    cable, diameter, image, calibration = scene
    shape = register_on_plane(image, calibration, BLUE, N_POINTS, diameter / 2,
                              start_near=cable[0], label="xi_0")
    assert shape.points.shape == (N_POINTS, 3) and shape.frame_id == "robot_base"
    truth = resample_by_arc_length(cable, N_POINTS) + [0.0, 0.0, diameter / 2]
    comparison = compare_shapes(truth[None], [shape], end_order="keep")
    assert comparison.euclidean_mean < 1e-3
    assert distance_to_curve(shape.points, cable).max() < 1e-3
    np.testing.assert_allclose(shape.points[:, 2], diameter / 2, atol=1e-9)


def test_start_near_chooses_the_first_end(scene):
    cable, diameter, image, calibration = scene
    forward = register_on_plane(image, calibration, BLUE, N_POINTS, diameter / 2,
                                start_near=cable[0])
    backward = register_on_plane(image, calibration, BLUE, N_POINTS, diameter / 2,
                                 start_near=cable[-1])
    np.testing.assert_allclose(backward.points, forward.points[::-1], atol=1e-9)
    assert np.linalg.norm(forward.points[0, :2] - cable[0, :2]) < 2e-3


def test_registration_with_a_depth_image(scene):
    cable, diameter, image, calibration = scene
    x, y = plane_maps(INTRINSICS, CAMERA_TO_ROBOT, diameter / 2, 1)
    in_camera = transform_points(invert_pose(CAMERA_TO_ROBOT),
                                 np.stack([x, y, np.full_like(x, diameter / 2)], axis=-1))
    depth = np.rint(in_camera[..., 2] / 1e-4).astype(np.uint16)  # 0.1 mm units
    depth[::7, ::5] = 0  # holes
    shape = register_with_depth(image, depth, calibration, BLUE, N_POINTS, depth_scale=1e-4,
                                start_near=cable[0])
    truth = resample_by_arc_length(cable, N_POINTS) + [0.0, 0.0, diameter / 2]
    assert np.linalg.norm(shape.points - truth, axis=1).mean() < 1e-3
    with pytest.raises(ValueError, match="has no depth"):
        register_with_depth(image, np.zeros_like(depth), calibration, BLUE, N_POINTS)
    # the images of another camera or resolution are refused, as register_on_plane refuses
    # its image: a depth image half the size would read the depth of other pixels
    half = cv2.resize(depth, (depth.shape[1] // 2, depth.shape[0] // 2),
                      interpolation=cv2.INTER_NEAREST)
    with pytest.raises(ValueError, match=r"depth_image: got 320 x 240 px, expected 640 x 480"):
        register_with_depth(image, half, calibration, BLUE, N_POINTS, depth_scale=1e-4)
    with pytest.raises(ValueError, match=r"^image: got 320 x 240 px, expected 640 x 480"):
        register_with_depth(cv2.resize(image, (320, 240)), depth, calibration, BLUE, N_POINTS,
                            depth_scale=1e-4)


def test_red_cable_with_hue_wrap_around():
    cable = sine_cable(yaw=0.8, amplitude=0.04)
    image = render([(cable, 0.006, SECOND_BGR)])
    line = extract_centreline(image, RED)
    assert line.length > 300  # px: the whole cable, ~0.4 m at ~1 mm per px
    with pytest.raises(CentrelineError, match="no cable found"):
        extract_centreline(image, BLUE)


def test_two_cables_are_an_error():
    first = sine_cable(yaw=0.3, amplitude=0.02, length=0.3, centre=(0.3, -0.06))
    second = sine_cable(yaw=0.3, amplitude=0.02, length=0.3, centre=(0.4, 0.08))
    image = render([(first, 0.006, CABLE_BGR), (second, 0.006, CABLE_BGR)])
    with pytest.raises(CentrelineError, match="2 separate regions of the cable's colour"):
        extract_centreline(image, BLUE)
    # a differently coloured second cable is not in the way
    image = render([(first, 0.006, CABLE_BGR), (second, 0.006, SECOND_BGR)])
    assert extract_centreline(image, BLUE).length > 200


def test_crossing_and_branch_are_errors():
    theta = np.linspace(-3.5, 3.5, 300)  # a prolate cycloid: one loop, crossing at +-2.22 rad
    loop = np.column_stack([0.35 + 0.03 * theta - 0.08 * np.sin(theta),
                            -0.03 - 0.08 * np.cos(theta), 0 * theta])
    image = render([(loop, 0.006, CABLE_BGR)])
    with pytest.raises(CentrelineError, match="branches or crosses itself|closed loop"):
        extract_centreline(image, BLUE)
    main = np.array([[0.2, 0.0, 0.0], [0.5, 0.0, 0.0]])
    branch = np.array([[0.35, 0.0, 0.0], [0.38, 0.1, 0.0]])
    image = render([(main, 0.006, CABLE_BGR), (branch, 0.006, CABLE_BGR)])
    with pytest.raises(CentrelineError, match="branches or crosses itself"):
        extract_centreline(image, BLUE)


def test_deprojection_inverts_projection():
    rng = np.random.default_rng(3)
    points = np.column_stack([rng.uniform(-0.2, 0.2, 50), rng.uniform(-0.15, 0.15, 50),
                              rng.uniform(0.4, 0.8, 50)])  # camera frame [m]
    pixels, _ = cv2.projectPoints(points, np.zeros(3), np.zeros(3), INTRINSICS.matrix,
                                  INTRINSICS.distortion_array)
    pixels = pixels.reshape(-1, 2)
    np.testing.assert_allclose(deproject_depth(pixels, points[:, 2], INTRINSICS), points,
                               atol=1e-6)  # undistortPoints iterates to ~1e-6 m here
    on_table = np.column_stack([rng.uniform(0.2, 0.5, 20), rng.uniform(-0.15, 0.15, 20),
                                np.full(20, 0.003)])
    in_camera = transform_points(invert_pose(CAMERA_TO_ROBOT), on_table)
    pix, _ = cv2.projectPoints(in_camera, np.zeros(3), np.zeros(3), INTRINSICS.matrix,
                               INTRINSICS.distortion_array)
    np.testing.assert_allclose(
        deproject_to_plane(pix.reshape(-1, 2), INTRINSICS, CAMERA_TO_ROBOT, 0.003), on_table,
        atol=1e-6)
    with pytest.raises(ValueError, match="does not reach the plane"):
        deproject_to_plane(pix.reshape(-1, 2), INTRINSICS, CAMERA_TO_ROBOT, 1.0)
    with pytest.raises(ValueError, match="depths: depth"):
        deproject_depth(pixels, -points[:, 2], INTRINSICS)


def test_depth_at_pixels_skips_holes():
    depth = np.full((10, 12), 500, np.uint16)
    depth[4, 5] = 0
    depth[0:3, 0:3] = 0
    got = depth_at_pixels(depth, [[5, 4], [0, 0], [11, 9]], depth_scale=0.001, window=1)
    np.testing.assert_allclose(got[[0, 2]], 0.5)
    assert np.isnan(got[1])
    with pytest.raises(ValueError, match="outside the 12x10 image"):
        depth_at_pixels(depth, [[12, 0]])


def test_bad_inputs():
    image = render()
    with pytest.raises(ValueError, match="H in"):
        HsvRange((200, 0, 0), (10, 255, 255))
    with pytest.raises(ValueError, match="S range"):
        HsvRange((0, 200, 0), (10, 100, 255))
    with pytest.raises(ValueError, match="uint8 BGR colour image"):
        extract_centreline(image[..., 0], BLUE)
    with pytest.raises(ValueError, match="start_near"):
        extract_centreline(render([(sine_cable(), 0.006, CABLE_BGR)]), BLUE,
                           start_near=(1.0, 2.0, 3.0))


def test_calibrate_and_register_from_the_command_line(tmp_path, capsys):
    """`dloplan calibrate` then `dloplan register` as docs/vision.md runs them. `register`
    refused every `--hsv` ("low: got (100.0, ...), expected integers": the option was parsed
    as floats) and, past that, every image ("expected an array of points, got
    RegisteredShape"): it had never registered a shape. Now the shape is the drawn cable's
    within 1 mm; `--json` prints JSON; an image of another size than the intrinsics', a
    calibration that failed its check and a folder are refused (exit 2, naming them)."""
    import json

    from scipy.spatial.transform import Rotation

    from dloplan.cli import main
    from dloplan.vision import read_shapes

    cable = sine_cable()
    image = render([(cable, 0.006, CABLE_BGR)])
    cv2.imwrite(str(tmp_path / "scene.png"), image)
    cv2.imwrite(str(tmp_path / "big.png"), cv2.resize(image, (1280, 960)))
    i = INTRINSICS
    (tmp_path / "intrinsics.json").write_text(json.dumps({
        "fx": i.fx, "fy": i.fy, "cx": i.cx, "cy": i.cy, "width": i.width, "height": i.height,
        "distortion": list(i.distortion)}))
    for name, length in (("layout.json", MARKER_LENGTH), ("wrong.json", 0.05)):
        markers = [{"id": k, "pose": {
            "position": dict(zip("xyz", p[:3, 3].tolist(), strict=True)),
            "orientation": dict(zip("xyzw", Rotation.from_matrix(p[:3, :3]).as_quat().tolist(),
                                    strict=True))}} for k, p in MARKER_POSES.items()]
        (tmp_path / name).write_text(json.dumps({"dictionary": "DICT_4X4_50",
                                                 "marker_length": length, "markers": markers}))

    def run(*args):
        code = main([args[0], *(str(tmp_path / a) if a.endswith((".png", ".json", ".csv"))
                                else a for a in args[1:]), "-q"])
        out, err = capsys.readouterr()
        return code, out, err

    code, out, _ = run("calibrate", "scene.png", "--intrinsics", "intrinsics.json",
                       "--markers", "layout.json", "-o", "cal.json", "--json")
    assert code == 0 and json.loads(out)["success"]
    assert run("calibrate", "scene.png", "--intrinsics", "intrinsics.json", "--markers",
               "wrong.json", "-o", "bad.json")[0] == 1  # written, with its RMS: 6.8 px
    hsv = ["--hsv", "95,120,60:120,255,255", "--links", "20", "--height", "0.003"]
    code, out, _ = run("register", "scene.png", "--calibration", "cal.json", *hsv,
                       "-o", "shapes.csv", "--json")
    assert code == 0 and json.loads(out)["shapes"][0]["points"] == 21
    (shape,) = read_shapes(tmp_path / "shapes.csv")
    assert shape.frame_id == "robot_base"
    assert distance_to_curve(shape.points, cable).max() < 1e-3
    # --start-near: the shape starts at the end nearer the point (the plan's first clip, so
    # that `correct` takes it as it comes; the default starts at the image's left)
    ends = [np.linalg.norm(shape.points[0, :2] - cable[k, :2]) for k in (0, -1)]
    far = cable[int(np.argmin(ends)) - 1]  # the drawn end the default shape does not start at
    assert run("register", "scene.png", "--calibration", "cal.json", *hsv, "--start-near",
               ",".join(f"{v:g}" for v in far), "-o", "turned.csv")[0] == 0
    (turned,) = read_shapes(tmp_path / "turned.csv")
    np.testing.assert_allclose(turned.points, shape.points[::-1], atol=2e-3)
    for args, fragment in (
            (("big.png", "--calibration", "cal.json"), "big.png: got 1280 x 960 px, expected "
             "640 x 480 px"),
            (("scene.png", "--calibration", "bad.json"), "the calibration failed its check"),
            ((str(tmp_path), "--calibration", "cal.json"), "is a folder; expected an image")):
        code, _, err = run("register", *args, *hsv, "-o", "other.csv")
        assert code == 2 and fragment in err and "Traceback" not in err
    assert not (tmp_path / "other.csv").exists()
    code, _, err = run("register", "scene.png", "--calibration", "cal.json", "--hsv",
                       "95,120,60:200,255,255", "-o", "other.csv")
    assert code == 2 and "argument --hsv: got '95,120,60:200,255,255', expected" in err
