"""Playback: the HTML page is offline and self-contained, renders frames in headless Chromium;
the GIF has one image per frame."""

import base64
import json
import re
import shutil
import subprocess

import numpy as np
import pytest

import thesis_rbd as rbd
from thesis_rbd.viz.html import playback_frames, render_html, write_html

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


@pytest.fixture(scope="module")
def trajectory():
    scene = rbd.scenes.get("thesis_example")
    run = rbd.simulate(scene.build(), 2.0)
    run.metadata.update(scene=scene.name, summary=scene.summary)
    return run


def embedded_data(page):
    match = re.search(r'<script type="application/json" id="trajectory-data">(.*?)</script>', page)
    return json.loads(match.group(1))


def test_playback_frames_thin_to_fps_and_keep_the_last():
    times = np.arange(0, 241) / 240  # 1 s at 240 Hz
    frames = playback_frames(times, fps=60)
    assert len(frames) == 61 and frames[0] == 0 and frames[-1] == 240
    np.testing.assert_allclose(np.diff(times[frames]), 1 / 60, atol=1e-9)
    # fewer recorded frames than the rate: every one is kept
    np.testing.assert_array_equal(playback_frames(times[::48], fps=60), np.arange(6))
    with pytest.raises(ValueError, match="fps must be positive"):
        playback_frames(times, 0)


def test_page_is_self_contained_and_offline(trajectory):
    page = render_html(trajectory)
    assert not re.search(r"https?:|//[a-z0-9.-]+\.[a-z]{2,}/|<link|\bsrc\s*=|@import|url\(", page)
    assert "<canvas" in page and 'id="play"' in page and 'type="range"' in page
    assert "<title>thesis_example</title>" in page


def test_page_embeds_the_trajectory(trajectory):
    data = embedded_data(render_html(trajectory, fps=30))
    frames = playback_frames(trajectory.times, 30)
    times = np.frombuffer(base64.b64decode(data["times"]), "<f8")
    np.testing.assert_array_equal(times, trajectory.times[frames])
    poses = np.frombuffer(base64.b64decode(data["poses"]), "<f4").reshape(len(frames), 2, 7)
    np.testing.assert_allclose(poses[..., :3], trajectory.positions[frames], atol=1e-6)
    np.testing.assert_allclose(poses[..., 3:], trajectory.orientations[frames], atol=1e-7)
    faces = np.frombuffer(base64.b64decode(data["bodies"][1]["faces"]), "<u4").reshape(-1, 3)
    np.testing.assert_array_equal(faces, trajectory.meshes[1].faces)
    assert [b["name"] for b in data["bodies"]] == ["box1", "box2"]


def test_script_closing_tag_in_a_name_cannot_break_the_page(trajectory):
    trajectory.names[0] = "</script><b>x"
    try:
        page = render_html(trajectory)
    finally:
        trajectory.names[0] = "box1"
    assert page.count("</script>") == 2  # the data block's and the player's
    assert embedded_data(page)["bodies"][0]["name"] == "</script><b>x"


def find_chromium():
    return next((path for name in CHROMIUM_NAMES if (path := shutil.which(name))), None)


def test_page_renders_frames_in_headless_chromium(trajectory, tmp_path):
    browser = find_chromium()
    if browser is None:
        pytest.skip("headless Chromium not found: apt-get install chromium to run this check")
    report, dom = chromium_self_test(browser, write_html(trajectory, tmp_path / "play.html"))
    assert report["bodies"] == 2 and report["frames"] == len(playback_frames(trajectory.times, 60))
    images = report["images"]
    assert [image["frame"] for image in images] == [0, report["frames"] // 2, report["frames"] - 1]
    for image in images:
        assert image["painted"] > 2000, image  # the boxes cover thousands of pixels
    # the pushed box moves and turns: the first and last images differ
    assert images[0]["checksum"] != images[-1]["checksum"]
    # the playback loop kept drawing after the self-test (4 = first frame + 3 self-test draws)
    rendered = int(re.search(r'data-frames-rendered="(\d+)"', dom).group(1))
    assert rendered > 4


def chromium_self_test(browser, page):
    """Open ``page`` with ``#selftest`` in headless Chromium; return its report and the DOM."""
    profile = page.parent / "profile"
    result = subprocess.run(
        [
            browser,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            f"--user-data-dir={profile}",
            "--window-size=800,600",
            "--virtual-time-budget=3000",
            "--dump-dom",
            f"{page.resolve().as_uri()}#selftest",
        ],
        capture_output=True,
        text=True,
        timeout=90,
    )
    dom = result.stdout
    match = re.search(r'<pre id="selftest-result">(.*?)</pre>', dom)
    assert match, f"no self-test report in the DOM; stderr: {result.stderr[-2000:]}"
    return json.loads(match.group(1)), dom


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


# ---------------------------------------------------------------------- recorded contacts
@pytest.fixture(scope="module")
def tori_run():
    """The tori demo from x = -0.5 to -0.3: B cuts through A, with contacts every frame."""
    scene = rbd.scenes.get("tori_demo")
    world = scene.build()
    world.step(150)  # 2.5 s at 1/60 s: B's centre at x = -0.5
    run = rbd.simulate(world, 0.2, record_contacts=True)
    run.metadata.update(scene=scene.name)
    return run


def test_page_embeds_the_contacts_of_the_frames_it_keeps(tori_run):
    data = embedded_data(render_html(tori_run, fps=30))
    frames = playback_frames(tori_run.times, 30)
    offsets = np.frombuffer(base64.b64decode(data["contacts"]["offsets"]), "<u4")
    points = np.frombuffer(base64.b64decode(data["contacts"]["points"]), "<f4").reshape(-1, 3)
    normals = np.frombuffer(base64.b64decode(data["contacts"]["normals"]), "<f4").reshape(-1, 3)
    assert len(offsets) == len(frames) + 1 and offsets[-1] == len(points) == len(normals)
    for k, frame in enumerate(frames):
        recorded = tori_run.contacts(int(frame))
        assert len(recorded["points"]) > 0
        rows = slice(offsets[k], offsets[k + 1])
        np.testing.assert_allclose(points[rows], recorded["points"], atol=1e-6)
        np.testing.assert_allclose(normals[rows], recorded["normals"], atol=1e-6)


def test_page_without_contacts_has_no_contact_data(trajectory):
    assert "contacts" not in embedded_data(render_html(trajectory))


def test_page_draws_the_contacts_in_headless_chromium(tori_run, tmp_path):
    browser = find_chromium()
    if browser is None:
        pytest.skip("headless Chromium not found: apt-get install chromium to run this check")
    report, _ = chromium_self_test(browser, write_html(tori_run, tmp_path / "play.html"))
    images = report["images"]
    assert len(images) == 4  # first, middle, last and the frame with the most contacts
    busiest = images[-1]
    assert busiest["contacts"] == tori_run.contact_counts().max() > 0
    # every contact lies in front of the camera, so every one is drawn
    assert all(image["contactsDrawn"] == image["contacts"] > 0 for image in images)


def test_gif_draws_the_contacts(tori_run, tmp_path):
    pytest.importorskip("matplotlib")
    from PIL import Image

    from thesis_rbd.viz.gif import write_gif

    with_dots = write_gif(tori_run, tmp_path / "dots.gif", fps=10, size_pixels=160)
    without = rbd.Trajectory(
        tori_run.times,
        tori_run.positions,
        tori_run.orientations,
        tori_run.names,
        tori_run.meshes,
        tori_run.centers_of_mass,
        tori_run.static,
    )
    plain = write_gif(without, tmp_path / "plain.gif", fps=10, size_pixels=160)

    def red_pixels(path):
        with Image.open(path) as image:
            rgb = np.asarray(image.convert("RGB")).astype(int)
        return int(np.sum((rgb[..., 0] > 200) & (rgb[..., 1] < 80) & (rgb[..., 2] < 120)))

    assert red_pixels(with_dots) > red_pixels(plain) + 5
