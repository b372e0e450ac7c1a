"""Playback: the HTML page is viser's offline client with the run embedded; in headless Chromium
it draws the bodies with WebGL where a ray cast says they are (nearest surface first, so
bodies that interpenetrate are drawn right), animates, and draws recorded contacts. The GIF has
one image per frame."""

import re
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from tests.chromium import (
    HeadlessChromium,
    canvas_rect,
    file_url,
    hide_notifications,
    require_chromium,
)
from tests.viser_recording import node_updates, node_values, recording, value_at
from thesis_rbd.viz.frames import playback_frames
from thesis_rbd.viz.html import render_html, write_html
from thesis_rbd.viz.viser_scene import (
    PALETTE,
    camera_pose,
    scene_bounds,
    wxyz_from_xyzw,
    xyzw_from_wxyz,
)

VISER_FOV = np.radians(75.0)  # viser's default vertical field of view


@pytest.fixture(scope="module")
def trajectory():
    scene = rbd.scenes.get("thesis_example")
    run = rbd.simulate(scene.build(), 2.0)
    run.metadata.update(scene=scene.name, summary=scene.summary)
    return run


def test_playback_frames_thin_to_fps_and_keep_the_last():
    times = np.arange(0, 241) / 240  # 1 s at 240 Hz
    frames = playback_frames(times, fps=60)
    assert len(frames) == 61 and frames[0] == 0 and frames[-1] == 240
    np.testing.assert_allclose(np.diff(times[frames]), 1 / 60, atol=1e-9)
    # fewer recorded frames than the rate: every one is kept
    np.testing.assert_array_equal(playback_frames(times[::48], fps=60), np.arange(6))
    with pytest.raises(ValueError, match="fps must be positive"):
        playback_frames(times, 0)


def test_quaternion_reorder_round_trips_and_agrees_with_viser():
    import viser.transforms as vtf

    xyzw = Rotation.random(20, random_state=3).as_quat()
    np.testing.assert_array_equal(xyzw_from_wxyz(wxyz_from_xyzw(xyzw)), xyzw)
    for q in xyzw:
        np.testing.assert_allclose(
            vtf.SO3(wxyz_from_xyzw(q)).as_matrix(), Rotation.from_quat(q).as_matrix(), atol=1e-12
        )


def test_page_is_self_contained_and_offline(trajectory):
    page = render_html(trajectory)
    # the only URL is the SVG namespace name inside viser's script; every link is inline data
    assert set(re_urls(page)) <= {"http://www.w3.org/2000/svg"}
    assert not any(
        not value.startswith(("data:", "#")) for value in re_attribute_values(page, ("src", "href"))
    )
    assert "<title>thesis_example</title>" in page
    assert recording(page)["durationSeconds"] == pytest.approx(2.0)


def re_urls(page):
    return re.findall(r"https?://[^\s\"'`)<>]+", page)


def re_attribute_values(page, names):
    alternatives = "|".join(names)
    return re.findall(rf"<[a-z]+[^>]*?\b(?:{alternatives})\s*=\s*\"([^\"]*)\"", page)


def test_page_embeds_every_kept_frame_of_the_trajectory(trajectory):
    record = recording(render_html(trajectory, fps=30))
    frames = playback_frames(trajectory.times, 30)
    for body in range(trajectory.body_count):
        node = f"/bodies/{body}_{trajectory.names[body]}"
        # viser sends a pose only when it changes from its default, (0, 0, 0) and identity
        positions = [(0.0, [0.0, 0.0, 0.0])] + node_values(
            record, "SetPositionMessage", node, "position"
        )
        orientations = [(0.0, [1.0, 0.0, 0.0, 0.0])] + node_values(
            record, "SetOrientationMessage", node, "wxyz"
        )
        for frame in frames:
            t = trajectory.times[frame] - trajectory.times[0]
            np.testing.assert_allclose(
                value_at(positions, t), trajectory.positions[frame, body], atol=1e-9
            )
            np.testing.assert_allclose(
                xyzw_from_wxyz(np.array(value_at(orientations, t))),
                trajectory.orientations[frame, body],
                atol=1e-9,
            )
        mesh = next(
            m["props"] for _, m in record["messages"] if m["type"] == "MeshMessage"
            and m["name"] == node
        )  # fmt: skip
        np.testing.assert_array_equal(mesh["faces"].reshape(-1, 3), trajectory.meshes[body].faces)
        np.testing.assert_allclose(
            mesh["vertices"].reshape(-1, 3),
            trajectory.meshes[body].vertices - trajectory.centers_of_mass[body],
            atol=1e-6,
        )


def test_a_script_closing_tag_in_the_title_cannot_break_the_page(trajectory):
    page = render_html(trajectory, title="</script><b>x")
    assert "</script><b>x" not in page
    assert "&lt;/script&gt;&lt;b&gt;x" in page


# ---------------------------------------------------------------------- recorded contacts
CONTACT_POINTS = np.array([[0.0, -1.4, 1.2], [0.8, -1.4, 1.2]])  # in the air, in front of A


@pytest.fixture(scope="module")
def showcase():
    """Three bodies seen by the camera, no simulation needed:

    A, a unit cube at the origin, pierced by B, a bar turned 30 degrees about z (they
    interpenetrate: which one shows at a pixel is decided by depth); C, a cube moving from
    x = -2 to x = 2 over 4 s at y = 2.5. Two contacts float in front of A at every frame.
    """
    times = np.linspace(0.0, 4.0, 241)
    T = len(times)
    positions = np.zeros((T, 3, 3))
    positions[:, 1] = (0.3, 0.0, 0.1)
    positions[:, 2, 0] = np.linspace(-2.0, 2.0, T)
    positions[:, 2, 1] = 2.5
    orientations = np.zeros((T, 3, 4))
    orientations[..., 3] = 1.0
    orientations[:, 1] = Rotation.from_euler("z", 30, degrees=True).as_quat()
    meshes = [rbd.shapes.box((1, 1, 1)), rbd.shapes.box((1.6, 0.4, 0.4)), rbd.shapes.box((1, 1, 1))]
    contacts = {
        "points": np.tile(CONTACT_POINTS, (T, 1)),
        "normals": np.tile([[0.0, 0.0, 1.0]], (2 * T, 1)),
        "bodies": np.tile([[0, 1]], (2 * T, 1)),
        "offsets": np.arange(T + 1) * 2,
    }
    return rbd.Trajectory(
        times, positions, orientations, ["A", "B", "C"], meshes, np.zeros((3, 3)),
        metadata={"scene": "showcase"}, contacts=contacts,
    )  # fmt: skip


def test_page_embeds_the_contacts_of_the_frames_it_keeps():
    scene = rbd.scenes.get("tori_demo")
    world = scene.build()
    world.step(150)  # 2.5 s at 1/60 s: B cuts through A
    run = rbd.simulate(world, 0.2, record_contacts=True)
    record = recording(render_html(run, fps=30))
    frames = playback_frames(run.times, 30)
    points = [(0.0, None)] + node_updates(record, "/contacts/points", "points")
    normals = [(0.0, None)] + node_updates(record, "/contacts/normals", "points")
    shown = [(0.0, False)] + node_values(
        record, "SetSceneNodeVisibilityMessage", "/contacts/points", "visible"
    )
    for frame in frames[1:]:
        t = run.times[frame] - run.times[0]
        recorded = run.contacts(int(frame))
        assert len(recorded["points"]) > 0 and value_at(shown, t)
        np.testing.assert_allclose(
            value_at(points, t).reshape(-1, 3), recorded["points"], atol=1e-6
        )
        ticks = value_at(normals, t).reshape(-1, 2, 3)
        np.testing.assert_allclose(ticks[:, 0], recorded["points"], atol=1e-6)
        direction = ticks[:, 1] - ticks[:, 0]
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        np.testing.assert_allclose(direction, recorded["normals"], atol=1e-5)


def test_a_contact_between_kept_frames_shows_at_the_next_kept_frame():
    """A one-step impact (frame 2) thinned away: kept frame 4 shows it, frame 8 does not."""
    T, impact = 9, np.array([[0.5, 0.0, -0.5]])
    counts = np.array([0, 0, 1, 0, 0, 0, 0, 0, 0])
    run = rbd.Trajectory(
        np.arange(T) / 10, np.zeros((T, 1, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (T, 1, 1)), ["a"],
        [rbd.shapes.box((1, 1, 1))], np.zeros((1, 3)),
        contacts={"points": impact, "normals": [[0.0, 0.0, 1.0]], "bodies": [[0, 0]],
                  "offsets": np.concatenate([[0], np.cumsum(counts)])},
    )  # fmt: skip
    record = recording(render_html(run, fps=2.5))  # keeps frames 0, 4 and 8
    shown = [(0.0, False)] + node_values(
        record, "SetSceneNodeVisibilityMessage", "/contacts/points", "visible"
    )
    points = node_updates(record, "/contacts/points", "points")
    assert [value_at(shown, t) for t in (0.0, 0.4, 0.8)] == [False, True, False]
    np.testing.assert_allclose(value_at(points, 0.4).reshape(-1, 3), impact)


def test_page_without_contacts_never_shows_them(trajectory):
    record = recording(render_html(trajectory))
    assert not any(
        visible
        for _, visible in node_values(
            record, "SetSceneNodeVisibilityMessage", "/contacts/points", "visible"
        )
    )


# ---------------------------------------------------------------------- joints
def test_page_draws_each_joint_on_its_body_and_on_the_world():
    """The pendulum's hinge (anchor at the origin, axis y): a dot and an axis segment on the
    ball, in its frame (a child of its node, which viser moves with it), and on the world. At
    every kept frame the ball's recorded pose carries its dot onto the hinge and its segment
    onto the world's."""
    run = rbd.simulate(rbd.scenes.get("pendulum").build(), 0.5)
    record = recording(render_html(run, fps=30))
    ball = "/bodies/0_ball"

    def drawn(kind, node):
        (props,) = [m["props"] for _, m in record["messages"] if m["type"] == kind
                    and m["name"] == node]  # fmt: skip
        return props["points"].reshape(-1, 3)

    np.testing.assert_allclose(drawn("PointCloudMessage", "/joint_anchors"), [[0.0, 0.0, 0.0]])
    world_axis = drawn("LineSegmentsMessage", "/joint_axes")
    np.testing.assert_allclose(world_axis[:, [0, 2]], 0.0)
    assert world_axis[0, 1] == pytest.approx(-world_axis[1, 1]) and world_axis[1, 1] > 0
    np.testing.assert_allclose(drawn("PointCloudMessage", f"{ball}/joint_anchors"), [[-1, 0, 0]])
    ball_axis = drawn("LineSegmentsMessage", f"{ball}/joint_axes")
    positions = [(0.0, [0.0, 0.0, 0.0])] + node_values(
        record, "SetPositionMessage", ball, "position"
    )
    orientations = node_values(record, "SetOrientationMessage", ball, "wxyz")
    for frame in playback_frames(run.times, 30)[1:]:
        t = run.times[frame] - run.times[0]
        pose = Rotation.from_quat(xyzw_from_wxyz(np.array(value_at(orientations, t))))
        place = np.asarray(value_at(positions, t))
        np.testing.assert_allclose(pose.apply([-1.0, 0.0, 0.0]) + place, 0.0, atol=1e-6)
        np.testing.assert_allclose(pose.apply(ball_axis) + place, world_axis, atol=1e-6)


def test_page_without_joints_draws_none(trajectory):
    record = recording(render_html(trajectory))
    assert not [m["name"] for _, m in record["messages"] if "joint" in m.get("name", "")]


# ---------------------------------------------------------------------- in a browser
def camera_rays(rect, lower, upper, pixels):
    """World rays through (k, 2) pixel (x, y) of the canvas, as viser's camera sees them."""
    position, look_at = camera_pose(lower, upper, VISER_FOV)
    forward = (look_at - position) / np.linalg.norm(look_at - position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    width, height = rect["width"], rect["height"]
    half = np.tan(0.5 * VISER_FOV)
    x = (2.0 * (pixels[:, 0] + 0.5 - rect["left"]) / width - 1.0) * half * width / height
    y = (1.0 - 2.0 * (pixels[:, 1] + 0.5 - rect["top"]) / height) * half
    directions = forward + x[:, None] * right + y[:, None] * up
    return position, directions / np.linalg.norm(directions, axis=1, keepdims=True)


def ray_box_distance(origin, directions, center, rotation, extents):
    """(k,) distance along each ray to a box (slab test; inf where it misses)."""
    local_origin = rotation.T @ (origin - center)
    local = directions @ rotation
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-0.5 * extents - local_origin) / local
        t2 = (0.5 * extents - local_origin) / local
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return np.where((near <= far) & (far > 0), near, np.inf)


def project(rect, lower, upper, points):
    """(k, 2) canvas pixels of world points."""
    position, look_at = camera_pose(lower, upper, VISER_FOV)
    forward = (look_at - position) / np.linalg.norm(look_at - position)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    relative = np.asarray(points) - position
    depth = relative @ forward
    half = np.tan(0.5 * VISER_FOV)
    x = relative @ right / depth / (half * rect["width"] / rect["height"])
    y = relative @ up / depth / half
    return np.stack(
        [
            rect["left"] + 0.5 * (x + 1.0) * rect["width"],
            rect["top"] + 0.5 * (1.0 - y) * rect["height"],
        ],
        axis=1,
    )


def hue_class(rgb):
    """Which palette body a pixel shows by its hue: 0 orange-red, 1 blue, 2 green, -1 none."""
    r, g, b = (rgb[..., k].astype(int) for k in range(3))
    return np.select(
        [(r - b > 50) & (r - g > 30), (b - r > 50) & (b - g > 30), (g - r > 30) & (g - b > 30)],
        [0, 1, 2],
        -1,
    )


def paused_at(browser):
    """Pause the page's playback (space bar) and return the time it shows."""
    browser.call("Input.dispatchKeyEvent", type="keyDown", key=" ", code="Space", keyCode=32)
    browser.call("Input.dispatchKeyEvent", type="keyUp", key=" ", code="Space", keyCode=32)
    time.sleep(0.3)
    return float(browser.evaluate("document.querySelector('input').value"))


def test_page_draws_depth_correct_animated_bodies_and_contacts_in_chromium(showcase, tmp_path):
    require_chromium()
    assert [tuple(PALETTE[k]) for k in range(3)] == [(214, 96, 61), (61, 126, 214), (92, 170, 90)]
    page = write_html(showcase, tmp_path / "play.html")
    lower, upper = scene_bounds(
        showcase.meshes, showcase.centers_of_mass, showcase.positions, showcase.orientations
    )
    with HeadlessChromium() as browser:
        browser.open(file_url(page))
        rect = canvas_rect(browser)
        hide_notifications(browser)
        # it plays: the time shown advances
        browser.wait_for("parseFloat(document.querySelector('input').value) > 0.3", 90)
        first_time = paused_at(browser)
        time.sleep(1.0)  # paused: the picture settles (viser fades nodes in)
        first = browser.screenshot()
        browser.call("Input.dispatchKeyEvent", type="keyDown", key=" ", code="Space", keyCode=32)
        browser.call("Input.dispatchKeyEvent", type="keyUp", key=" ", code="Space", keyCode=32)
        browser.wait_for(
            f"Math.abs(parseFloat(document.querySelector('input').value) - {first_time}) > 1.2",
            60,
        )
        second_time = paused_at(browser)
        time.sleep(1.0)
        second = browser.screenshot()

    # 1. depth: at every 6th pixel, the body a ray cast meets first is the one drawn
    ys, xs = np.mgrid[0 : int(rect["height"]) : 6, 0 : int(rect["width"]) : 6]
    pixels = np.stack([xs.ravel(), ys.ravel()], axis=1).astype(float)
    origin, directions = camera_rays(rect, lower, upper, pixels)
    extents = [np.array([1.0, 1.0, 1.0]), np.array([1.6, 0.4, 0.4])]
    distances = np.stack(
        [
            ray_box_distance(
                origin,
                directions,
                showcase.positions[0, body],
                Rotation.from_quat(showcase.orientations[0, body]).as_matrix(),
                extents[body],
            )
            for body in (0, 1)
        ]
    )
    expected = np.where(np.isfinite(distances.min(axis=0)), distances.argmin(axis=0), -1)
    drawn = hue_class(first[pixels[:, 1].astype(int), pixels[:, 0].astype(int)])
    on_a_or_b = expected >= 0
    assert np.count_nonzero(expected == 1) > 50 and np.count_nonzero(expected == 0) > 150
    # both bodies are drawn where they are: A and B each show where nearest (edges aside)
    agree = np.mean(drawn[on_a_or_b] == expected[on_a_or_b])
    assert agree > 0.97, agree
    assert np.mean(np.isin(drawn[~on_a_or_b], (0, 1))) < 0.01  # and nowhere else

    # 2. animation: C is drawn where it is at each paused time, and the pictures differ
    for picture, shown_time in ((first, first_time), (second, second_time)):
        center_c = np.array([-2.0 + shown_time, 2.5, 0.0])
        expected_pixel = project(rect, lower, upper, [center_c])[0]
        green = np.argwhere(hue_class(picture) == 2)[:, ::-1]
        assert len(green) > 200
        # the time box shows 0.1 s: C is within 0.05 m of where that time puts it
        assert np.linalg.norm(green.mean(axis=0) - expected_pixel) < 25
    assert abs(first_time - second_time) > 1.0
    assert np.count_nonzero(np.any(first != second, axis=2)) > 1000

    # 3. contacts: red dots at the recorded points, in the air where no body is
    for x, y in project(rect, lower, upper, CONTACT_POINTS).round().astype(int):
        patch = first[y - 2 : y + 3, x - 2 : x + 3].astype(int)
        red = (patch[..., 0] > 180) & (patch[..., 1] < 90) & (patch[..., 2] < 120)
        assert np.count_nonzero(red) >= 9, patch


def test_gif_has_one_image_per_frame(trajectory, tmp_path):
    pytest.importorskip("matplotlib")
    from PIL import Image

    from thesis_rbd.viz.gif import write_gif

    short = rbd.Trajectory(
        trajectory.times[:121],
        trajectory.positions[:121],
        trajectory.orientations[:121],
        trajectory.names,
        trajectory.meshes,
        trajectory.centers_of_mass,
    )
    path = write_gif(short, tmp_path / "run.gif", fps=10, size_pixels=200)
    with Image.open(path) as image:
        assert image.format == "GIF" and image.size == (200, 200)
        assert image.n_frames == len(playback_frames(short.times, 10)) == 6


def test_gif_draws_the_contacts(showcase, tmp_path):
    pytest.importorskip("matplotlib")
    from PIL import Image

    from thesis_rbd.viz.gif import write_gif

    without = rbd.Trajectory(
        showcase.times, showcase.positions, showcase.orientations,
        showcase.names, showcase.meshes, showcase.centers_of_mass,
    )  # fmt: skip
    with_dots = write_gif(showcase, tmp_path / "dots.gif", fps=2, size_pixels=160)
    plain = write_gif(without, tmp_path / "plain.gif", fps=2, size_pixels=160)

    def red_pixels(path):
        with Image.open(path) as image:
            rgb = np.asarray(image.convert("RGB")).astype(int)
        return int(np.sum((rgb[..., 0] > 200) & (rgb[..., 1] < 80) & (rgb[..., 2] < 120)))

    assert red_pixels(with_dots) > red_pixels(plain) + 5
