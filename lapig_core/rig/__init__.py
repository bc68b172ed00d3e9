# SPDX-License-Identifier: GPL-3.0-or-later
"""A real projector and camera behind the capture-device seam (lapig_core.capture.device).

- ``projector_window``: the projector output, a borderless full-screen window on a chosen display, run
  by a helper process (``window_process``, SDL2 through PySDL2) because Blender cannot place a window
  on a monitor; the add-on talks to it over a pipe. ``list_displays()`` names the displays SDL sees.
- ``cameras``: cameras that return what they see: ``OpenCVCamera`` (cv2.VideoCapture by index, URL or
  file, with its settings locked where the backend allows and read back) and ``TetheredFolderCamera``
  (each new image file in a watched folder is the next frame: DSLR tethering programs, gphoto2).
- ``frame_code`` and ``sync``: every shown frame carries a code the camera reads back, so a stale,
  dropped or torn frame is captured again, and the display-to-capture latency is measured, not guessed.
- ``rig_device``: the CaptureDevice of a projector output and a camera, with the sync above.
- ``simulated``: a rig with a real rig's faults (latency, dropped and repeated frames, drifting auto
  exposure, noise, a slow start, unplugging), for the tests and ``bench hardware``.

Interfaces (duck-typed; every method may raise RigError with a message that says what to change):

ProjectorOutput
    size -> (width, height) of the display in pixels, shown 1:1
    show(frame uint8 (H, W, 3) RGB) -> float: time.perf_counter() once the frame is on screen
    describe() -> dict (recorded in setup.json)
    close()

Camera
    size -> (width, height)
    grab() -> (image uint8 (H, W, 3) RGB, time.perf_counter() when it was read)
    flush(): drop what the camera buffered, so the next grab() is of now
    describe() -> dict: the backend, and each setting as asked and as read back (recorded in setup.json)
    close()
"""


class RigError(RuntimeError):
    """A real device failed or refused: the message says what happened and what to change."""
