"""The Python package against the command line: the same images bit for bit, the same
relighting, the same one-line messages; and its own controls (progress, cancellation,
Ctrl-C). The command line is `$RAYLINK_BIN`, else `raylink` on the PATH."""

import _thread
import os
import shutil
import signal
import subprocess
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

import raylink

SCENES = Path(__file__).resolve().parents[2] / "scenes"
CORNELL = SCENES / "cornell-box.toml"
ROOM = SCENES / "network-room.toml"
# A small network: built in well under a second.
NETWORK = dict(slopes=8, intercept_step=0.03125, width=40, height=30)
NETWORK_FLAGS = ["--slopes", "8", "--intercept-step", "0.03125", "--width", "40",
                 "--height", "30"]


@pytest.fixture
def deadline():
    """A render the test fails to stop ends with TimeoutError after 30 s, not hours later:
    the package checks for signals while it renders."""

    def expire(signum, frame):
        raise TimeoutError("the render was not stopped")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(30)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


def cli() -> str:
    found = os.environ.get("RAYLINK_BIN") or shutil.which("raylink")
    assert found, "set RAYLINK_BIN to the raylink command (cargo build --release)"
    return found


def run_cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([cli(), *map(str, args)], capture_output=True, text=True)


def cli_render(tmp_path, name, *args) -> Path:
    out = tmp_path / name
    done = run_cli(*args, "-o", out, "-q")
    assert done.returncode == 0, done.stderr
    return out


@pytest.mark.parametrize("integrator,spp", [("path", 16), ("whitted", 4), ("bdpt", 4)])
def test_a_render_equals_the_command_lines_bit_for_bit(tmp_path, integrator, spp):
    exr = cli_render(tmp_path, "cli.exr", "render", CORNELL, "--integrator", integrator,
                     "--spp", spp, "--width", 64, "--height", 64, "--seed", 1)
    image = raylink.render(CORNELL, integrator=integrator, spp=spp, width=64, height=64,
                           seed=1, output=tmp_path / "py.exr")
    assert image.dtype == np.float32 and image.shape == (64, 64, 3)
    assert image.any(), "a black image would match trivially"
    reference = raylink.read_image(exr)
    assert np.array_equal(image, reference)
    # The package's own output holds the same pixels.
    assert np.array_equal(raylink.read_image(tmp_path / "py.exr"), reference)


def test_another_seed_gives_another_image():
    a = raylink.render(CORNELL, integrator="path", spp=4, width=32, height=32, seed=1)
    b = raylink.render(CORNELL, integrator="path", spp=4, width=32, height=32, seed=2)
    assert not np.array_equal(a, b)


def test_aovs_equal_the_command_lines(tmp_path):
    cli_render(tmp_path, "cli.exr", "render", CORNELL, "--width", 48, "--height", 32,
               "--spp", 1, "--aov")
    aovs = raylink.aovs(CORNELL, width=48, height=32, spp=1)
    assert aovs["albedo"].shape == (32, 48, 3) and aovs["depth"].shape == (32, 48)
    assert np.array_equal(aovs["albedo"], raylink.read_image(tmp_path / "cli.albedo.exr"))
    assert np.array_equal(aovs["normal"], raylink.read_image(tmp_path / "cli.normal.exr"))
    # A single-valued image is read back with its value in every channel.
    assert np.array_equal(aovs["depth"], raylink.read_image(tmp_path / "cli.depth.exr")[..., 0])
    assert aovs["depth"].max() > 0


def test_a_scene_built_from_a_dict_renders_as_its_file():
    with open(CORNELL, "rb") as f:
        description = tomllib.load(f)
    scene = raylink.scene_from_dict(description, base_dir=SCENES)
    from_dict = raylink.render(scene, integrator="path", spp=4, width=32, height=32, seed=3)
    from_file = raylink.render(CORNELL, integrator="path", spp=4, width=32, height=32, seed=3)
    assert np.array_equal(from_dict, from_file)


def test_progress_shows_every_pass_and_the_last_is_the_image():
    passes = []

    def progress(event):
        if event.image is not None:
            passes.append((event.spp, event.image.copy()))

    renderer = raylink.Renderer(CORNELL, integrator="path", spp=8, width=32, height=32)
    rendered = renderer.render(progress=progress)
    spps = [spp for spp, _ in passes]
    assert spps == sorted(spps) and len(set(spps)) == len(spps)
    assert spps[-1] == 8 and not rendered.partial
    assert np.array_equal(passes[-1][1], rendered.image)


def test_a_pixel_technique_reports_its_progress_in_tiles():
    events = []
    renderer = raylink.Renderer(CORNELL, integrator="whitted", spp=16, width=96, height=96)
    rendered = renderer.render(progress=events.append)
    rendering = [(e.done, e.total) for e in events if e.phase == "render"]
    assert rendering, [repr(e) for e in events]
    assert all(e.image is None for e in events), "Whitted has no passes to show"
    done = [d for d, _ in rendering]
    assert done == sorted(done)
    assert all(t is not None and d <= t for d, t in rendering)
    assert rendering[-1][0] == rendering[-1][1], "the last report is the whole image"
    assert not rendered.partial


def test_a_callback_returning_false_stops_the_render_within_a_second(deadline):
    # A million samples a pixel: hours, were it not stopped.
    renderer = raylink.Renderer(CORNELL, integrator="path", spp=1 << 20, width=64, height=64)
    cancelled_at = []

    def progress(event):
        if event.spp:
            cancelled_at.append(time.monotonic())
            return False
        return None

    rendered = renderer.render(progress=progress)
    stopped = time.monotonic() - cancelled_at[0]
    assert len(cancelled_at) == 1, "the callback ran after it cancelled"
    assert rendered.partial
    assert 0 < rendered.samples < 64 * 64 * (1 << 20)
    assert rendered.image.any()
    assert stopped < 1.0, f"stopped {stopped:.2f} s after the cancel"


def test_ctrl_c_stops_a_render_and_raises_keyboard_interrupt(deadline):
    renderer = raylink.Renderer(CORNELL, integrator="path", spp=1 << 20, width=64, height=64)
    interrupted_at = []

    def progress(event):
        if event.spp and not interrupted_at:
            interrupted_at.append(time.monotonic())
            _thread.interrupt_main()  # what Ctrl-C does to the main thread

    with pytest.raises(KeyboardInterrupt):
        renderer.render(progress=progress)
    assert time.monotonic() - interrupted_at[0] < 1.0
    # The renderer is still usable: it renders again (stopped after its first pass).
    again = renderer.render(progress=lambda event: False if event.spp else None)
    assert again.partial and again.image.any()


def test_an_exception_in_the_callback_stops_the_render_and_is_raised(deadline):
    renderer = raylink.Renderer(CORNELL, integrator="path", spp=1 << 20, width=32, height=32)

    def progress(event):
        if event.spp:
            raise ValueError("enough")

    with pytest.raises(ValueError, match="enough"):
        renderer.render(progress=progress)


def test_a_network_built_once_is_relit_as_the_command_line_relights_it(tmp_path):
    net = tmp_path / "room.rlnet"
    # Built and saved from Python; the first render equals the command line's render from it.
    built = raylink.render(ROOM, integrator="network", network_file=net, **NETWORK)
    assert net.exists()
    again = cli_render(tmp_path, "a.exr", "render", ROOM, "--integrator", "network",
                       "--network-file", net, *NETWORK_FLAGS)
    assert np.array_equal(built, raylink.read_image(again))
    for light, factor in [("lamp=2", 2.0), ("lamp=1,0.5,0.25", (1.0, 0.5, 0.25))]:
        exr = cli_render(tmp_path, "relit.exr", "relight", ROOM, "--network-file", net,
                         "--light", light, *NETWORK_FLAGS)
        relit = raylink.relight(ROOM, net, {"lamp": factor}, **NETWORK)
        assert np.array_equal(relit, raylink.read_image(exr))
        assert not np.array_equal(relit, built)
    # Twice the lamp is twice the light: the network's light is linear in its emission.
    doubled = raylink.relight(ROOM, net, {"lamp": 2.0}, **NETWORK)
    np.testing.assert_allclose(doubled, 2 * built, rtol=1e-3, atol=1e-6)


def cli_message(*args) -> str:
    done = run_cli(*args)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("raylink: error: "), done.stderr
    return lines[0][len("raylink: error: "):]


def python_message(call) -> str:
    with pytest.raises(raylink.RaylinkError) as e:
        call()
    message = str(e.value)
    assert "\n" not in message
    return message


def test_bad_input_raises_the_command_lines_message(tmp_path):
    broken = tmp_path / "broken.toml"
    broken.write_text(CORNELL.read_text().replace("fov = ", "fov = -", 1))
    out = tmp_path / "x.exr"
    cases = [
        (["render", tmp_path / "missing.toml", "-o", out],
         lambda: raylink.render(tmp_path / "missing.toml")),
        (["render", broken, "-o", out], lambda: raylink.render(broken)),
        (["render", CORNELL, "--integrator", "path", "--ab", "2", "-o", out],
         lambda: raylink.render(CORNELL, integrator="path", ab=2)),
        (["render", CORNELL, "--max-depth", "5000", "-o", out],
         lambda: raylink.render(CORNELL, max_depth=5000)),
        (["render", CORNELL, "-o", tmp_path / "x.unknown"],
         lambda: raylink.render(CORNELL, spp=1, width=4, height=4, output=tmp_path / "x.unknown")),
    ]
    for args, call in cases:
        expected = cli_message(*args)
        # A setting is named by its keyword where the command line names its flag.
        for flag in ["--ab", "--max-depth"]:
            expected = expected.replace(flag, flag[2:].replace("-", "_"))
        assert python_message(call) == expected
    assert not out.exists()


def test_a_relight_with_other_network_settings_is_refused_as_on_the_command_line(tmp_path):
    net = tmp_path / "room.rlnet"
    raylink.render(ROOM, integrator="network", network_file=net, **NETWORK)
    other = dict(NETWORK, slopes=9)
    flags = [f if f != "8" else "9" for f in NETWORK_FLAGS]
    expected = cli_message("relight", ROOM, "--network-file", net, "--light", "lamp=2",
                           *flags, "-o", tmp_path / "x.exr")
    assert python_message(lambda: raylink.relight(ROOM, net, {"lamp": 2}, **other)) == expected


def test_unknown_keywords_are_type_errors():
    with pytest.raises(TypeError, match="sppp"):
        raylink.render(CORNELL, sppp=4)


def test_images_written_and_read_back_are_the_same(tmp_path):
    rng = np.random.default_rng(1)
    image = rng.random((5, 7, 3), dtype=np.float32)
    raylink.write_image(tmp_path / "a.exr", image)
    assert np.array_equal(raylink.read_image(tmp_path / "a.exr"), image)


def test_a_colour_space_is_the_command_lines(tmp_path):
    # The same render written by Python and by the command line in Rec.2020: the same
    # pixels; a colour space that does not exist is refused, naming the choices.
    rendered = raylink.Renderer(CORNELL, integrator="path", spp=2, width=16, height=16).render()
    rendered.write(tmp_path / "py.exr", color_space="rec2020")
    cli = cli_render(tmp_path, "cli.exr", "render", CORNELL, "--integrator", "path", "--spp",
                     "2", "--width", "16", "--height", "16", "--color-space", "rec2020")
    py = raylink.read_image(tmp_path / "py.exr")
    assert np.array_equal(py, raylink.read_image(cli))
    assert not np.array_equal(py, rendered.image)
    with pytest.raises(raylink.RaylinkError, match="rec2020, dci-p3 or aces2065-1"):
        raylink.write_image(tmp_path / "x.exr", rendered.image, color_space="adobe")
