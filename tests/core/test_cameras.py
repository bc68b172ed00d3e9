# SPDX-License-Identifier: GPL-3.0-or-later
"""The rig's cameras without hardware: a video file written here stands for a camera, a fake
cv2.VideoCapture for a driver's controls, and a thread writing into a folder for a tethering program."""
import shutil
import sys
import threading
import time

import cv2
import numpy as np
import pytest

from lapig.lapig_core.rig import RigError
from lapig.lapig_core.rig import cameras
from lapig.lapig_core.rig.cameras import OpenCVCamera, list_cameras, native_backend, resolve_backend, to_rgb
from lapig.lapig_core.rig import tethered
from lapig.lapig_core.rig.gphoto import GphotoTrigger
from lapig.lapig_core.rig.tethered import TetheredFolderCamera, decode_frame, ends_complete

COLOURS = [(255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 0), (0, 255, 255), (128, 128, 128)]  # RGB
W, H = 64, 48


def write_video(path, colours=COLOURS, fps=10):
    """An MJPG AVI (the headless build writes it) whose frames are flat RGB colours, in order."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (W, H))
    assert writer.isOpened()
    for colour in colours:
        writer.write(np.full((H, W, 3), colour[::-1], np.uint8))
    writer.release()
    return path


def flat(colour, dtype=np.uint8):
    return np.full((H, W, 3), colour, dtype)


def png_bytes(rgb):
    ok, data = cv2.imencode(".png", np.ascontiguousarray(rgb[:, :, ::-1]))
    assert ok
    return data.tobytes()


def assert_colour(image, colour, tol=6):
    assert image.dtype == np.uint8 and image.shape == (H, W, 3)
    assert np.abs(image.reshape(-1, 3).mean(0) - np.array(colour)).max() <= tol, image.reshape(-1, 3).mean(0)


# -- OpenCVCamera on a video file -------------------------------------------------------------------
@pytest.fixture
def video(tmp_path):
    return write_video(tmp_path / "colours.avi")


def test_a_video_file_gives_its_frames_in_order_as_rgb(video):
    with OpenCVCamera(video) as camera:
        assert camera.size == (W, H)
        times = []
        for colour in COLOURS:
            image, read_at = camera.grab()
            assert_colour(image, colour)
            times.append(read_at)
        assert times == sorted(times)


def test_describe_records_each_setting_as_asked_and_read_back(video):
    with OpenCVCamera(video, exposure=100, gain=3, white_balance=4500) as camera:
        info = camera.describe()
    assert info["kind"] == "opencv" and info["source_kind"] == "file" and info["backend"] == "FFMPEG"
    settings = info["settings"]
    assert settings["exposure"]["asked"] == 100 and "read_back" in settings["exposure"]
    assert settings["gain"]["asked"] == 3 and settings["white_balance"]["asked"] == 4500
    assert settings["width"]["read_back"] == W and settings["width"]["took"] is None  # not asked
    assert settings["focus"]["asked"] is None and settings["focus"]["took"] is None
    # a file takes no control: each one asked is listed, none is an error
    assert {"auto_exposure", "exposure", "gain", "autofocus", "auto_white_balance", "white_balance",
            "buffer_size"} <= set(info["not_locked"])
    assert "focus" not in info["not_locked"]
    assert info["flush"].startswith("none")


def test_a_file_past_its_end_says_the_camera_stopped(video):
    with OpenCVCamera(video) as camera:
        for _ in COLOURS:
            camera.grab()
        with pytest.raises(RigError, match="stopped answering.*colours.avi.*has no frame after the 6"):
            camera.grab()


def test_flush_of_a_file_drops_nothing(video):
    with OpenCVCamera(video) as camera:
        camera.flush()
        assert_colour(camera.grab()[0], COLOURS[0])


def test_a_closed_camera_says_so(video):
    camera = OpenCVCamera(video)
    camera.close()
    camera.close()
    with pytest.raises(RigError, match="is closed"):
        camera.grab()


def test_sources_that_do_not_open_say_what_to_change(tmp_path, capfd):
    with pytest.raises(RigError, match="no video file at .*missing.avi"):
        OpenCVCamera(tmp_path / "missing.avi")
    text = tmp_path / "notes.avi"
    text.write_text("not a video")
    with pytest.raises(RigError, match="cannot open video file .*notes.avi with the FFMPEG backend.*decode"):
        OpenCVCamera(text)
    if sys.platform.startswith("linux"):
        with pytest.raises(RigError, match=r"no camera answers at index 63 \(the V4L2 backend\).*list_cameras"):
            OpenCVCamera(63)
    with pytest.raises(RigError, match="unknown camera backend 'quicktime'.*v4l2"):
        OpenCVCamera(0, backend="quicktime")
    with pytest.raises(RigError, match="negative"):
        OpenCVCamera(-1)
    assert "WARN" not in capfd.readouterr().err  # OpenCV's own warnings stay quiet


def test_list_cameras_probes_quietly(capfd):
    found = list_cameras(max_index=3)
    assert all({"index", "backend", "width", "height"} <= set(entry) for entry in found)
    assert "can't open camera by index" not in capfd.readouterr().err


def test_backends_per_platform_and_by_name():
    assert native_backend("linux") == cv2.CAP_V4L2
    assert native_backend("win32") == cv2.CAP_DSHOW
    assert native_backend("darwin") == cv2.CAP_AVFOUNDATION
    assert resolve_backend("auto", "file") == cv2.CAP_FFMPEG
    assert resolve_backend("auto", "url") == cv2.CAP_FFMPEG
    assert resolve_backend("FFMPEG", "index") == cv2.CAP_FFMPEG
    assert resolve_backend("any", "index") == cv2.CAP_ANY


def test_frames_of_any_layout_become_rgb():
    bgr = np.zeros((2, 2, 3), np.uint8)
    bgr[..., 0] = 200  # blue
    assert to_rgb(bgr)[0, 0].tolist() == [0, 0, 200]
    assert to_rgb(np.full((2, 2), 7, np.uint8))[0, 0].tolist() == [7, 7, 7]
    assert to_rgb(np.dstack([bgr, np.zeros((2, 2), np.uint8)]))[0, 0].tolist() == [0, 0, 200]
    assert to_rgb(np.full((2, 2, 3), 257 * 9, np.uint16))[0, 0].tolist() == [9, 9, 9]


# -- OpenCVCamera on a fake driver --------------------------------------------------------------
class FakeCapture:
    """A V4L2 camera as OpenCV shows it. raw_menu: CAP_PROP_AUTO_EXPOSURE takes the raw menu value
    (1 manual, 3 aperture priority) and refuses 0.25; otherwise 0.25 means manual and reads back so.
    `unsupported` controls refuse set() and read -1. Frames: `buffered` ones come at once, then
    each new one after a frame period; each frame's pixels hold its number."""

    def __init__(self, raw_menu=True, unsupported=(cv2.CAP_PROP_FOCUS, cv2.CAP_PROP_AUTOFOCUS),
                 buffered=0, fps=100.0, fail_reads=False):
        self.raw_menu, self.unsupported, self.fail_reads = raw_menu, set(unsupported), fail_reads
        self.values = {cv2.CAP_PROP_FRAME_WIDTH: W, cv2.CAP_PROP_FRAME_HEIGHT: H, cv2.CAP_PROP_FPS: fps,
                       cv2.CAP_PROP_AUTO_EXPOSURE: 3.0 if raw_menu else 0.75, cv2.CAP_PROP_EXPOSURE: 156,
                       cv2.CAP_PROP_GAIN: 0, cv2.CAP_PROP_AUTO_WB: 1, cv2.CAP_PROP_WB_TEMPERATURE: 4600,
                       cv2.CAP_PROP_BUFFERSIZE: 4}
        self.queue = list(range(buffered))
        self.next_number = buffered
        self.released = False

    def isOpened(self):
        return True

    def getBackendName(self):
        return "V4L2"

    def get(self, prop):
        return -1.0 if prop in self.unsupported else float(self.values.get(prop, 0.0))

    def set(self, prop, value):
        if prop in self.unsupported:
            return False
        if prop == cv2.CAP_PROP_AUTO_EXPOSURE and self.raw_menu and int(value) not in (1, 3):
            return False
        self.values[prop] = value
        return True

    def grab(self):
        if self.fail_reads:
            return False
        if not self.queue:
            time.sleep(1.0 / self.values[cv2.CAP_PROP_FPS])
            self.queue.append(self.next_number)
            self.next_number += 1
        self.current = self.queue.pop(0)
        return True

    def read(self):
        if not self.grab():
            return False, None
        return True, np.full((H, W, 3), self.current, np.uint8)

    def release(self):
        self.released = True


@pytest.fixture
def fake(monkeypatch):
    made = {}

    def use(**options):
        capture = FakeCapture(**options)
        monkeypatch.setattr(cameras, "_open_capture", lambda source, api, params: capture)
        made["capture"] = capture
        return capture
    monkeypatch.setattr(cameras, "READ_RETRY_S", 0.0)
    return use


def test_auto_exposure_off_tries_the_raw_menu_value_when_0_25_does_not_take(fake):
    fake(raw_menu=True)
    with OpenCVCamera(0, backend="v4l2", exposure=150, gain=2, white_balance=5000) as camera:
        settings = camera.describe()["settings"]
        not_locked = camera.describe()["not_locked"]
    auto = settings["auto_exposure"]
    assert auto["tried"] == [0.25, 1.0] and auto["asked"] == 1.0 and auto["read_back"] == 1.0 and auto["took"]
    assert settings["exposure"] == {"asked": 150, "before": 156.0, "accepted": True, "read_back": 150.0,
                                    "took": True}
    assert settings["auto_white_balance"]["read_back"] == 0.0 and settings["white_balance"]["took"]
    assert settings["buffer_size"]["took"] and settings["buffer_size"]["read_back"] == 1.0
    # the driver has no focus control: recorded, not an error
    assert settings["autofocus"]["read_back"] == -1.0 and not_locked == ["autofocus"]


def test_auto_exposure_off_where_0_25_is_manual(fake):
    fake(raw_menu=False, unsupported=())
    with OpenCVCamera(0, backend="v4l2", focus=20) as camera:
        info = camera.describe()
    assert info["settings"]["auto_exposure"]["read_back"] == 0.25 and "tried" not in info["settings"]["auto_exposure"]
    assert info["settings"]["focus"]["took"] and info["not_locked"] == []
    assert info["settings"]["exposure"] == {"asked": None, "before": 156.0, "read_back": 156.0, "took": None}


def test_a_control_a_later_one_undid_is_not_locked(fake):
    capture = fake(unsupported=())
    original_set = capture.set

    def set_resetting_gain(prop, value):  # a driver that resets the gain when the buffers change
        if prop == cv2.CAP_PROP_BUFFERSIZE:
            capture.values[cv2.CAP_PROP_GAIN] = 0
        return original_set(prop, value)
    capture.set = set_resetting_gain
    with OpenCVCamera(0, backend="v4l2", gain=8) as camera:
        assert camera.describe()["not_locked"] == ["gain"]
        assert camera.set_control("gain", 8)["took"] and camera.describe()["not_locked"] == []


def test_flush_drops_the_buffered_frames(fake):
    fake(buffered=4, fps=50.0)
    with OpenCVCamera(0, backend="v4l2") as camera:
        camera.flush()
        image, _ = camera.grab()
        flush = camera.describe()["flush"]
    assert flush["drained"] and flush["frames_dropped"] == 5  # 4 at once, then one that waited
    assert image[0, 0, 0] == 5  # the frame after the drain, not frame 0 of the buffer


def test_an_unplugged_camera_says_so_after_retrying(fake):
    fake(fail_reads=True)
    with OpenCVCamera(0, backend="v4l2") as camera:
        with pytest.raises(RigError, match=r"stopped answering \(unplugged\?\): camera 0 gave no frame in 3 tries"):
            camera.grab()
        with pytest.raises(RigError, match="stopped answering"):
            camera.flush()


def test_a_stream_url_keeps_its_password_out_of_messages_and_records(monkeypatch):
    class Closed(FakeCapture):
        def isOpened(self):
            return False
    seen = {}

    def open_capture(source, api, params):
        seen.update(api=api, params=params)
        return Closed()
    monkeypatch.setattr(cameras, "_open_capture", open_capture)
    with pytest.raises(RigError) as error:
        OpenCVCamera("rtsp://admin:secret@10.0.0.9:554/stream1", open_timeout_s=2)
    assert "secret" not in str(error.value) and "rtsp://admin:***@10.0.0.9:554/stream1" in str(error.value)
    assert seen["api"] == cv2.CAP_FFMPEG
    assert seen["params"] == [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, 2000, cv2.CAP_PROP_READ_TIMEOUT_MSEC, 2000]


# -- TetheredFolderCamera -----------------------------------------------------------------------
def write_in_two_parts(path, data, pause_s):
    with open(path, "wb") as handle:
        handle.write(data[: len(data) // 2])
        handle.flush()
        time.sleep(pause_s)
        handle.write(data[len(data) // 2:])


def jpeg_bytes(rgb):
    ok, data = cv2.imencode(".jpg", np.ascontiguousarray(rgb[:, :, ::-1]), [cv2.IMWRITE_JPEG_QUALITY, 95])
    assert ok
    return data.tobytes()


def tiff_bytes(rgb):
    ok, data = cv2.imencode(".tif", np.ascontiguousarray(rgb[:, :, ::-1]))
    assert ok
    return data.tobytes()


def test_new_files_are_frames_in_order_whole_and_8_bit(tmp_path):
    (tmp_path / "before.png").write_bytes(png_bytes(flat((9, 9, 9))))  # present at start: not a frame
    camera = TetheredFolderCamera(tmp_path, timeout_s=10, settle_s=0.15)
    assert camera.size == (W, H)  # before any frame: the newest image the folder held
    sixteen = np.full((H, W, 3), 0, np.uint16)
    sixteen[..., 0], sixteen[..., 1], sixteen[..., 2] = 257 * 10, 257 * 20, 257 * 200

    def tether():
        time.sleep(0.1)
        (tmp_path / "a.png").write_bytes(png_bytes(flat(COLOURS[0])))
        time.sleep(0.1)
        write_in_two_parts(tmp_path / "b.jpg", jpeg_bytes(flat(COLOURS[1])), 0.4)  # paused past settle_s
        (tmp_path / "c.png").write_bytes(png_bytes(sixteen))
        write_in_two_parts(tmp_path / "d.tif", tiff_bytes(flat(COLOURS[2])), 0.05)  # no end marker
        (tmp_path / "notes.txt").write_text("not an image")
    writer = threading.Thread(target=tether)
    writer.start()
    try:
        frames = [camera.grab() for _ in range(4)]
    finally:
        writer.join()
    assert_colour(frames[0][0], COLOURS[0], tol=0)
    assert_colour(frames[1][0], COLOURS[1])  # whole: a JPEG read half-written decodes half grey
    assert frames[2][0].dtype == np.uint8 and frames[2][0][0, 0].tolist() == [10, 20, 200]
    assert_colour(frames[3][0], COLOURS[2], tol=0)
    assert [t for _, t in frames] == sorted(t for _, t in frames)
    info = camera.describe()
    assert info["frames_read"] == 4 and info["file_bit_depths"] == {"8": 3, "16": 1}
    with pytest.raises(RigError, match="no new image"):
        TetheredFolderCamera(tmp_path, timeout_s=0.2).grab()  # every file there is old now


def test_a_lenient_decoder_still_never_sees_a_half_written_file(tmp_path, monkeypatch):
    """This OpenCV refuses truncated files; others decode them in part. The size that has stopped
    changing and the end marker are what keep a file being written from being read."""
    read = []

    def lenient(data, keep_16_bit=False):
        read.append(len(data))
        return flat((0, 0, 0)), 8
    monkeypatch.setattr(tethered, "decode_frame", lenient)
    camera = TetheredFolderCamera(tmp_path, timeout_s=5, settle_s=0.4)
    tiff, jpeg = tiff_bytes(flat(COLOURS[0])), jpeg_bytes(flat(COLOURS[1]))
    first_read = threading.Event()

    def tether():
        write_in_two_parts(tmp_path / "a.tif", tiff, 0.15)  # paused for less than settle_s
        first_read.wait(5)
        write_in_two_parts(tmp_path / "b.jpg", jpeg, 0.6)  # paused for longer
    writer = threading.Thread(target=tether)
    writer.start()
    try:
        camera.grab()
        first_read.set()
        camera.grab()
    finally:
        writer.join()
    assert read == [len(tiff), len(jpeg)]


def test_end_markers():
    png, jpeg, tiff = png_bytes(flat(COLOURS[0])), jpeg_bytes(flat(COLOURS[0])), tiff_bytes(flat(COLOURS[0]))
    assert ends_complete(png) and ends_complete(jpeg) and ends_complete(jpeg + b"\x00" * 16)
    assert ends_complete(png[:-5]) is False and ends_complete(jpeg[:-40]) is False
    assert ends_complete(tiff) is None


def test_files_arriving_together_come_in_name_order_and_flush_forgets(tmp_path):
    camera = TetheredFolderCamera(tmp_path, timeout_s=2, settle_s=0.05)
    (tmp_path / "IMG_0002.JPG").write_bytes(jpeg_bytes(flat(COLOURS[1])))
    (tmp_path / "IMG_0001.png").write_bytes(png_bytes(flat(COLOURS[0])))
    assert_colour(camera.grab()[0], COLOURS[0], tol=0)
    assert_colour(camera.grab()[0], COLOURS[1])
    (tmp_path / "IMG_0003.png").write_bytes(png_bytes(flat(COLOURS[2])))
    camera.flush()
    (tmp_path / "IMG_0004.png").write_bytes(png_bytes(flat(COLOURS[3])))
    assert_colour(camera.grab()[0], COLOURS[3], tol=0)


def test_keep_16_bit_returns_float_frames(tmp_path):
    camera = TetheredFolderCamera(tmp_path, timeout_s=2, settle_s=0.05, keep_16_bit=True)
    (tmp_path / "x.png").write_bytes(png_bytes(np.full((H, W, 3), 1000, np.uint16)))
    image, _ = camera.grab()
    assert image.dtype == np.float32 and abs(float(image[0, 0, 0]) - 1000 / 65535) < 1e-7
    assert "float32" in camera.describe()["output"]


def test_no_new_file_times_out_with_what_to_check(tmp_path):
    camera = TetheredFolderCamera(tmp_path, timeout_s=0.3, settle_s=0.05)
    start = time.perf_counter()
    with pytest.raises(RigError, match=r"no new image in .* for 0\.3 s: is the tethering program saving there"):
        camera.grab()
    assert time.perf_counter() - start < 2
    with pytest.raises(RigError, match="known once it saved an image"):
        camera.size


def test_a_folder_deleted_mid_capture_says_it_is_gone(tmp_path):
    folder = tmp_path / "tether"
    folder.mkdir()
    camera = TetheredFolderCamera(folder, timeout_s=10, settle_s=0.05)
    remover = threading.Timer(0.2, shutil.rmtree, args=(folder,))
    remover.start()
    start = time.perf_counter()
    with pytest.raises(RigError, match="the tethered folder .*tether is gone"):
        camera.grab()
    remover.join()
    assert time.perf_counter() - start < 3
    with pytest.raises(RigError, match="does not exist"):
        TetheredFolderCamera(folder)


def test_a_file_that_never_decodes_is_named(tmp_path):
    camera = TetheredFolderCamera(tmp_path, timeout_s=0.4, settle_s=0.05)
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"\x00" * 100)
    with pytest.raises(RigError, match=r"broken.png stayed unreadable .*truncated"):
        camera.grab()


def test_decode_frame_of_grey_and_alpha():
    grey = cv2.imencode(".png", np.full((4, 4), 50, np.uint8))[1].tobytes()
    assert decode_frame(grey)[0][0, 0].tolist() == [50, 50, 50]
    bgra = np.zeros((4, 4, 4), np.uint8)
    bgra[..., 2], bgra[..., 3] = 90, 0  # red, fully transparent: a photograph's alpha is dropped
    assert decode_frame(cv2.imencode(".png", bgra)[1].tobytes())[0][0, 0].tolist() == [90, 0, 0]
    assert decode_frame(b"garbage") is None


# -- GphotoTrigger ------------------------------------------------------------------------------
def test_gphoto_command_names_files_in_shot_order(tmp_path):
    folder = tmp_path / "100%"
    trigger = GphotoTrigger(folder, prefix="shot", camera="Canon EOS 80D", port="usb:001,004")
    assert trigger.command(7) == ["gphoto2", "--camera", "Canon EOS 80D", "--port", "usb:001,004",
                                  "--capture-image-and-download", "--force-overwrite",
                                  "--filename", str(tmp_path / "100%%" / "shot_00007") + ".%C"]
    assert GphotoTrigger(folder).command(1)[1:3] == ["--capture-image-and-download", "--force-overwrite"]


def test_gphoto_missing_says_to_install_it(tmp_path):
    trigger = GphotoTrigger(tmp_path, executable="gphoto2-not-installed-here")
    assert not GphotoTrigger.available("gphoto2-not-installed-here")
    with pytest.raises(RigError, match="gphoto2 is not installed"):
        TetheredFolderCamera(tmp_path, timeout_s=1, trigger=trigger).grab()


@pytest.mark.skipif(sys.platform == "win32", reason="the stand-in gphoto2 is a POSIX script")
def test_a_triggered_shot_is_the_next_frame(tmp_path):
    folder = tmp_path / "shots"
    folder.mkdir()
    script = tmp_path / "fake-gphoto2"
    image = png_bytes(flat(COLOURS[4])).hex()
    script.write_text(f"#!{sys.executable}\n"
                      "import sys\n"
                      "if 'fail' in sys.argv[0]:\n"
                      "    sys.stderr.write('*** Error: Could not claim the USB device\\n'); sys.exit(1)\n"
                      "name = sys.argv[sys.argv.index('--filename') + 1].replace('%C', 'png')\n"
                      f"open(name, 'wb').write(bytes.fromhex('{image}'))\n")
    script.chmod(0o755)
    trigger = GphotoTrigger(folder, executable=str(script), timeout_s=20, prefix="t")
    with TetheredFolderCamera(folder, timeout_s=5, settle_s=0.05, trigger=trigger) as camera:
        assert_colour(camera.grab()[0], COLOURS[4], tol=0)
        assert trigger.shots == 1 and (folder / "t_00001.png").is_file()
        assert camera.describe()["trigger"]["command"][-1].endswith("t_00002.%C")
    failing = tmp_path / "fail-gphoto2"
    shutil.copy(script, failing)
    with pytest.raises(RigError, match="could not take a picture .*Could not claim the USB device"):
        GphotoTrigger(folder, executable=str(failing))()
