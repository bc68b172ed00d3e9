"""Looks of the world shaped by the object (issue 50, item 3), with synthetic geometry: a box on a floor ray cast
here in numpy as Blender's ray casts would give it, a step of two walls at two depths, and a captured surface
without a 3D model."""
import numpy as np
import pytest

torch = pytest.importorskip("torch")

from lapig.lapig_core.lgst.world import geometry as lg  # noqa: E402
from lapig.lapig_core.lgst.world.compose import compose  # noqa: E402
from lapig.lapig_core.lgst.world.stage import render, world_stage  # noqa: E402

pytestmark = pytest.mark.torch
H, W, F = 120, 160, 150.0


def _params(comp):
    stage = world_stage(comp)
    return stage.params


def _box_on_floor(pitch_deg=35.0, height=2.2):
    """A projector `height` m above a floor, pitched down, facing a box (1.2 m wide, 0.8 m high, 0.8 m deep, 3 m
    ahead): (points, normals, up) in projector coordinates, and each pixel's face ('floor', 'top', 'front')."""
    t = np.radians(pitch_deg)
    ahead, down = np.array([0, -np.sin(t), np.cos(t)]), np.array([0, -np.cos(t), -np.sin(t)])
    rot = np.stack([np.array([1.0, 0, 0]), down, ahead], 1)  # columns: the projector's x, y, z in the world
    origin = np.array([0.0, height, 0.0])
    ys, xs = np.mgrid[0:H, 0:W] + 0.5
    d = np.stack([(xs - W / 2) / F, (ys - H / 2) / F, np.ones_like(xs)], -1) @ rot.T
    best = np.full((H, W), np.inf)
    normal = np.zeros((H, W, 3))
    face = np.full((H, W), "", object)
    with np.errstate(divide="ignore", invalid="ignore"):
        tf = -origin[1] / d[..., 1]  # the floor y = 0
        hit = tf > 0
        best[hit], normal[hit], face[hit] = tf[hit], (0, 1, 0), "floor"
        lo, hi = np.array([-0.6, 0.0, 2.6]), np.array([0.6, 0.8, 3.4])
        t0, t1 = (lo - origin) / d, (hi - origin) / d
        near, far = np.minimum(t0, t1), np.maximum(t0, t1)
        enter, leave = near.max(-1), far.min(-1)
        box = (enter <= leave) & (enter > 0) & (enter < best)
        axis = near.argmax(-1)
    best[box] = enter[box]
    for a, name, n in ((1, "top", (0, 1, 0)), (2, "front", (0, 0, -1)), (0, "end", (1, 0, 0))):
        sel = box & (axis == a)
        normal[sel], face[sel] = n, name
    points_w = origin + best[..., None] * d
    points = (points_w - origin) @ rot
    normals = normal @ rot
    up = np.array([0.0, 1.0, 0.0]) @ rot
    points[~np.isfinite(best)] = np.nan
    return points, normals, up, face


def _geometry(**kw):
    points, normals, up, face = _box_on_floor(**kw)
    return lg.from_hits(points, normals, up, F, F, W / 2, H / 2), face


def test_the_box_on_the_floor_gives_tops_walls_downhill_and_its_crease_as_a_crevice():
    g, face = _geometry()
    assert g.source == "scene" and g.valid.mean() > 0.9
    assert g.up[face == "top"].mean() > 0.95 and g.up[face == "floor"].mean() > 0.95
    assert abs(g.up[face == "front"]).mean() < 0.05
    # on the front wall water runs straight down the image
    assert g.downhill[face == "front"][:, 1].mean() > 0.95
    # the crease where the front meets the floor lies in a crevice; the box's top edge stands out
    rows = np.flatnonzero((face == "front").any(1))
    col = W // 2
    crease = rows.max() + 1  # the floor just below the front
    assert g.cavity[crease - 1:crease + 2, col].max() > 0.5
    assert g.cavity[rows.min() - 2:rows.min() + 2, col].max() < 0.2 and g.curvature[rows.min(), col] != 0
    flat = (face == "floor") & (np.abs(np.arange(H)[:, None] - crease) > 12) & np.ones((1, W), bool)
    assert g.cavity[flat].mean() < 0.05
    d = g.to_dict()
    assert d["source"] == "scene" and 0 < d["tops_share"] < 1 and d["depth_m"][0] > 1


def test_snow_settles_on_the_tops_more_than_on_the_walls():
    g, face = _geometry()
    comp = compose("snowy rocks")
    assert [o.name for o in comp.overlays] == ["snow"]
    p = _params(comp)
    with torch.no_grad():
        shaped = render(comp, p, H, W, geometry=g)[0].permute(1, 2, 0).numpy()
        plain = render(comp, p, H, W)[0].permute(1, 2, 0).numpy()

    def brighter_on_tops(img):  # snow is the bright layer over grey rock
        return float(img[face == "top"].mean() - img[face == "front"].mean())

    assert brighter_on_tops(shaped) > brighter_on_tops(plain) + 0.08, (brighter_on_tops(shaped),
                                                                      brighter_on_tops(plain))
    assert shaped[face == "front"].mean() < plain[face == "front"].mean()  # less on the walls


def test_moss_and_dirt_gather_in_the_crevices():
    g, face = _geometry()
    crevice = g.cavity > 0.5
    flat = (g.cavity < 0.02) & g.valid
    assert crevice.sum() > 50 and flat.sum() > 1000
    comp = compose("mossy concrete")
    p = _params(comp)
    with torch.no_grad():
        img = render(comp, p, H, W, geometry=g)[0].permute(1, 2, 0).numpy()
    green = (img[..., 1] - img[..., [0, 2]].mean(-1)) > 0.06
    assert green[crevice].mean() > green[flat].mean() + 0.15, (green[crevice].mean(), green[flat].mean())
    comp = compose("old concrete")
    p = _params(comp)
    with torch.no_grad():
        dirty = render(comp, p, H, W, geometry=g)[0].mean(0).numpy()
        clean = render(comp, p, H, W)[0].mean(0).numpy()
    darker = 1 - dirty / np.maximum(clean, 1e-3)
    assert darker[crevice].mean() > darker[flat].mean() + 0.1


def _step(depths=(2.0, 4.0), h=H, w=W):
    """Two walls facing the projector: the left half at depths[0] m, the right at depths[1] m."""
    ys, xs = np.mgrid[0:h, 0:w] + 0.5
    z = np.where(xs < w / 2, depths[0], depths[1])
    points = np.stack([(xs - w / 2) * z / F, (ys - h / 2) * z / F, z], -1)
    normals = np.broadcast_to(np.array([0.0, 0.0, -1.0]), points.shape)
    return lg.from_hits(points, normals, np.array([0.0, -1.0, 0.0]), F, F, w / 2, h / 2)


def _course_period(lum: np.ndarray) -> float:
    """The brick courses' period in pixels: the strongest frequency of the rows' mean."""
    profile = lum.mean(1) - lum.mean()
    spectrum = np.abs(np.fft.rfft(profile * np.hanning(len(profile)), n=4096))
    spectrum[:8] = 0
    return 4096 / float(np.argmax(spectrum))


def test_bricks_keep_their_size_in_metres():
    h, w = 240, 160
    g = _step(h=h, w=w)
    comp = compose("bricks")
    p = _params(comp)
    with torch.no_grad():
        img = render(comp, p, h, w, geometry=g)[0].mean(0).numpy()
        flat = render(comp, p, h, w)[0].mean(0).numpy()
        half = render(comp, p, h // 2, w // 2, geometry=g)[0].mean(0).numpy()  # the frame at half the size
    near, far = _course_period(img[:, : w // 2 - 4]), _course_period(img[:, w // 2 + 4:])
    assert 1.7 < near / far < 2.3, (near, far)  # twice as far: half as many pixels per course
    # at the median depth (3 m) the courses are as many per frame as without the object
    plain = _course_period(flat[:, :w // 2])
    assert 1.3 < near / plain < 1.7 and 0.6 < far / plain < 0.9, (near, far, plain)
    assert 0.8 < 2 * _course_period(half[:, : w // 4 - 2]) / near < 1.25  # the same look at another size


def test_rust_runs_downhill():
    from lapig.lapig_core.lgst.world.stage import _smear_downhill

    dot = torch.zeros(40, 40)
    dot[10, 20] = 1.0
    down = torch.zeros(40, 40, 2)
    down[..., 1] = 1.0
    streak = _smear_downhill(dot, down)
    assert float(streak[11:20, 20].min()) > 0.2 and float(streak[:10, 20].max()) == 0.0  # below it, not above
    assert float(streak[20, 25]) == 0.0
    g = _step(depths=(3.0, 3.0))
    sideways = lg.LookGeometry(**{**g.__dict__, "downhill": np.stack([np.ones(g.shape), np.zeros(g.shape)], -1)})
    from lapig.lapig_core.lgst.world.catalog import by_name
    from lapig.lapig_core.lgst.world.stage import _geometry_maps, shaped_cover

    spots = torch.zeros(H, W)
    rng = np.random.default_rng(0)
    for y, x in rng.integers(0, (H, W), (30, 2)):  # rust spots of 3 px
        spots[max(0, y - 1):y + 2, max(0, x - 1):x + 2] = 1.0

    def tall(geometry, lag=6):  # stains alike along their streaks, not across
        rust = shaped_cover(by_name()["rust"], spots, _geometry_maps(geometry, H, W, None)).numpy()
        down = np.corrcoef(rust[:-lag].ravel(), rust[lag:].ravel())[0, 1]
        across = np.corrcoef(rust[:, :-lag].ravel(), rust[:, lag:].ravel())[0, 1]
        return down - across

    assert tall(g) > 0.1 and tall(sideways) < -0.1, (tall(g), tall(sideways))
    comp = compose("rust on steel")  # and in the look: it renders, in range, with the stains
    with torch.no_grad():
        img = render(comp, _params(comp), H, W, geometry=g)
    assert img.shape == (1, 3, H, W) and 0 <= float(img.min()) and float(img.max()) <= 1


def test_without_a_model_the_captured_surface_stands_in_and_says_so():
    surface = np.full((H, W, 3), 0.7, np.float32)
    surface[:, 70:78] = 0.2  # a dark joint
    g = lg.from_capture(surface)
    assert g.source == "capture" and "no 3D model" in g.note and g.up is None
    assert g.cavity[:, 72:76].mean() > 0.8 and g.cavity[:, :40].mean() < 0.05
    assert (g.downhill[..., 1] == 1).all()
    comp = compose("granite")  # no overlay, no weathering: the captured geometry changes nothing of it
    p = _params(comp)
    with torch.no_grad():
        assert torch.allclose(render(comp, p, H, W, geometry=g), render(comp, p, H, W), atol=1e-5)
    stage = world_stage(compose("mossy concrete"), geometry=g)
    assert stage.note.endswith("shaped by the capture")
    x = torch.full((1, 3, H, W), 0.5)
    with torch.no_grad():
        img = stage(x, x)[0].numpy()
    green = (img[1] - img[[0, 2]].mean(0)) > 0.06
    assert green[:, 71:77].mean() > green[:, :40].mean() + 0.15


def test_geometry_refuses_rays_that_land_on_nothing():
    nothing = np.full((4, 4, 3), np.nan)
    with pytest.raises(ValueError, match="land on nothing"):
        lg.from_hits(nothing, nothing, np.array([0, -1.0, 0]), 10, 10, 2, 2)
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        lg.from_capture(np.zeros((4, 4)))


def _wall_facing(depth=3.0):
    """A flat wall `depth` m ahead, facing the projector: points and normals in projector coordinates."""
    ys, xs = np.mgrid[0:H, 0:W] + 0.5
    points = np.stack([(xs - W / 2) / F * depth, (ys - H / 2) / F * depth, np.full(xs.shape, depth)], -1)
    normals = np.broadcast_to(np.array([0.0, 0.0, -1.0]), points.shape).copy()
    return points, normals, np.array([0.0, -1.0, 0.0])


def test_a_uv_map_lays_the_look_on_the_object_as_a_texture_in_metres():
    """Where the object has a UV map, the surface coordinates follow it (turned a quarter: the grain of wood runs
    down the wall, not across), scaled to metres; without one, or collapsed to a point, box mapping stays."""
    points, normals, up = _wall_facing()
    metres_x, metres_y = points[..., 0], points[..., 1]
    uv = np.stack([metres_y / 2.0, metres_x / 2.0], -1)  # one UV unit: 2 m, its u running down the wall
    g = lg.from_hits(points, normals, up, F, F, W / 2, H / 2, uv=uv)
    assert g.mapping == "uv" and g.to_dict()["mapping"] == "uv"
    assert np.allclose(g.surface_u, metres_y, atol=1e-4)  # u follows the map: down the wall, in metres
    assert np.allclose(np.abs(np.diff(g.surface_v, axis=1)), np.abs(np.diff(metres_x, axis=1)), atol=1e-4)
    box = lg.from_hits(points, normals, up, F, F, W / 2, H / 2)
    assert box.mapping == "box" and np.allclose(np.diff(box.surface_u, axis=1), np.diff(metres_x, axis=1), atol=1e-4)
    collapsed = lg.from_hits(points, normals, up, F, F, W / 2, H / 2, uv=np.zeros_like(uv))
    assert collapsed.mapping == "box"
    wood = compose("oak wood planks")
    turned = render(wood, _params(wood), H, W, geo=None, geometry=g)[0].mean(0)
    plain = render(wood, _params(wood), H, W, geo=None, geometry=box)[0].mean(0)

    def along(img, axis):  # how little the shade changes along an axis: the grain runs that way
        return float(np.abs(np.diff(img.numpy(), axis=axis)).mean())
    assert along(turned, 0) < along(turned, 1) and along(plain, 1) < along(plain, 0)


def test_a_result_keeps_its_geometry_and_a_show_makes_its_look_again_shaped_by_it(tmp_path):
    """look_geometry.npz beside result.json: read back whole (a damaged one reads as none), and the show's look of
    the result (look_from_result) is shaped by it as the still look was; "capture" makes it from the surface."""
    import json

    from show_fakes import fake_models

    from lapig.lapig_core.show.frames import look_from_result
    from lapig.lapig_core.show.model import Look

    models = fake_models()
    h, w = models.i_max.shape[-2:]
    step, _ = _geometry()  # the box on the floor: crevices, tops and walls
    path = tmp_path / lg.GEOMETRY_FILE
    path.write_bytes(lg.geometry_bytes(step))
    back = lg.load_geometry(path)
    assert back.mapping == step.mapping and back.source == "scene" and back.metres_across == step.metres_across
    assert all(np.array_equal(getattr(back, n), getattr(step, n), equal_nan=True) for n in lg._ARRAYS)
    (tmp_path / "damaged.npz").write_bytes(b"not a zip")
    assert lg.load_geometry(tmp_path / "damaged.npz") is None and lg.load_geometry(tmp_path / "none.npz") is None

    def result(name, source, keep):
        folder = tmp_path / name
        folder.mkdir()
        (folder / "result.json").write_text(json.dumps({
            "prompt": "ivy growing over old bricks", "backend": "styletransfer", "seed": 0, "psa": False,
            "lgst": {"geometry": {"source": source}} if source else {}}))
        if keep:
            (folder / lg.GEOMETRY_FILE).write_bytes(lg.geometry_bytes(step))
        return look_from_result(Look(str(folder)), models)

    shaped, plain, captured = result("kept", "scene", True), result("before", None, False), \
        result("capture", "capture", False)
    assert shaped.backend.geometry is not None and shaped.backend.geometry.source == "scene"
    assert plain.backend.geometry is None
    assert captured.backend.geometry is not None and captured.backend.geometry.source == "capture"
    assert shaped.base.shape == plain.base.shape == (1, 3, h, w)
    assert float((shaped.base - plain.base).abs().mean()) > 0.02  # the object shapes the show's look too
