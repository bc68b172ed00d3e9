"""`python -m lapig_addon bench prompts --json`: does the offline look follow the prompt?

Our own prompt set (none of the paper's): media, moods, named colours, art movements and 8 prompts in
other languages, each rendered on two surfaces (a drawn scene and the sakura texture), by the new
mapping (medium + palette + mood, multilingual embedder) and, side by side, by the old one (the 26
styles only, MiniLM).
  colour_adherence: the named colours are in the look's dominant palette (k-means; hue within 25
      degrees and HLS lightness within 0.2; grey-ish names by lightness only), share of colour prompts.
  mood_adherence: night/dark looks darker than the surface (mean luminance at least 0.03 lower),
      bright/sunny ones lighter, share of mood prompts.
  multilingual_agreement: share of the non-English prompts whose mapped look (medium and mood) is the
      one of their English counterpart in the set.
Sheets: out/bench_prompts/sheet_<group>.png. --psa-surfaces N also runs Table 1 (with against
without PSA, rendered with Cycles) for the first --prompts prompts of PSA_PROMPTS through bench_psa.

Named looks (issue 30, the art lexicon):
  paper_prompts_understood: share of the paper's nine prompts mapped to their entry with nothing
      unmatched.
  painter_adherence: share of the named entries of painter_checks.PAINTER_CHECKS whose look carries
      the palette written down for it (every check on both surfaces); the misses by name, with why.
  names_other_languages: share of named prompts in other languages (or misspelt) that find their entry.
  unknown_names_told: share of made-up names reported as unknown with the three nearest entries.
Sheets: out/bench_prompts/lexicon_<group>.png, every entry of a group by its name on both surfaces.
--psa-named puts the named prompts of PSA_NAMED_PROMPTS through Table 1 instead of PSA_PROMPTS.
"""
from __future__ import annotations

import os
import platform
import time
from contextlib import contextmanager

import numpy as np
import torch

from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.sheets import labelled_grid
from ...lapig_core.lgst import get_backend
from ...lapig_core.lgst.colours import colour_by_name
from .palette_measure import colour_present, dominant_palette
from .test_images import sheet_surfaces

# (prompt, group, expectation): colours: the names it should show; mood: "dark" / "light";
# english: the prompt of the set it translates
PROMPTS = (
    ("Make it a woodblock print", "media", {}),
    ("Turn it into a halftone newspaper print", "media", {}),
    ("Make it a Roman mosaic", "media", {}),
    ("A watercolour painting", "media", {}),
    ("Turn it into a line drawing in ink", "media", {}),
    ("Make it look like a comic book panel", "media", {}),
    ("Make it a screen-printed poster", "media", {}),
    ("Turn it into neon signs", "media", {}),
    ("A charcoal drawing", "media", {}),
    ("A cyanotype print", "media", {}),
    ("Make it a stained glass window", "media", {}),
    ("Make it night", "moods", {"mood": "dark"}),
    ("A dark, moody version", "moods", {"mood": "dark"}),
    ("Moonlit, at midnight", "moods", {"mood": "dark"}),
    ("Bright and sunny", "moods", {"mood": "light"}),
    ("Flooded with summer daylight", "moods", {"mood": "light"}),
    ("A sunny, cheerful day", "moods", {"mood": "light"}),
    ("At dusk", "moods", {}),
    ("In thick fog", "moods", {}),
    ("In deep blue and gold", "colours", {"colours": ["deep blue", "gold"]}),
    ("Sepia", "colours", {"colours": ["sepia"]}),
    ("Pastel pink and mint", "colours", {"colours": ["pastel pink", "mint"]}),
    ("A woodblock print in indigo and vermilion", "colours", {"colours": ["indigo", "vermilion"]}),
    ("A mosaic in turquoise and orange", "colours", {"colours": ["turquoise", "orange"]}),
    ("Emerald green and black", "colours", {"colours": ["emerald", "black"]}),
    ("Neon pink and electric blue lights", "colours", {"colours": ["neon pink", "electric blue"]}),
    ("In shades of purple", "colours", {"colours": ["purple"]}),
    ("A halftone in crimson", "colours", {"colours": ["crimson"]}),
    ("Burnt sienna and cream", "colours", {"colours": ["burnt sienna", "cream"]}),
    ("Teal and orange, like a movie poster", "colours", {"colours": ["teal", "orange"]}),
    ("A watercolour in pale yellow and sky blue", "colours", {"colours": ["pale yellow", "sky blue"]}),
    ("Pop art", "movements", {}),
    ("An impressionist painting", "movements", {}),
    ("Pointillism", "movements", {}),
    ("Fauvism", "movements", {}),
    ("Ukiyo-e", "movements", {}),
    ("Post-impressionism, like Van Gogh", "movements", {}),
    ("Expressionism", "movements", {}),
    ("Synthwave", "movements", {}),
    ("Fais-en un vitrail", "other languages", {"english": "Make it a stained glass window"}),
    ("Mach daraus einen Holzschnitt", "other languages", {"english": "Make it a woodblock print"}),
    ("Bei Nacht", "other languages", {"english": "Make it night"}),
    ("En azul profundo y dorado", "other languages", {"english": "In deep blue and gold"}),
    ("Un mosaico romano", "other languages", {"english": "Make it a Roman mosaic"}),
    ("ネオンサインにして", "other languages", {"english": "Turn it into neon signs"}),
    ("Um desenho a carvão", "other languages", {"english": "A charcoal drawing"}),
    ("Een aquarel", "other languages", {"english": "A watercolour painting"}),
)
# the PSA check: 10 of the new prompts, across the look library
PSA_PROMPTS = ("Make it a woodblock print", "Turn it into a halftone newspaper print", "Make it a Roman mosaic",
               "Turn it into neon signs", "Make it night", "In deep blue and gold", "Sepia",
               "A watercolour in pale yellow and sky blue", "Make it look like a comic book panel",
               "Bright and sunny")

# the PSA check of named looks (issue 30): 10 named entries across the lexicon's families
PSA_NAMED_PROMPTS = ("Make it a Klimt", "Mondrian", "Paint it like Monet's water lilies", "Hokusai's great wave",
                     "Imagine it as a traditional Indian miniature painting", "Make it a stained glass artwork",
                     "A Rothko", "Make it a Seurat", "Azulejo tiles", "Like Rembrandt")
# named prompts in other languages or misspelt -> the entry they must find
NAMES_ELSEWHERE = (("Un tableau de Monet", "Monet"), ("Im Stil von Gustav Klimt", "Klimt"),
                   ("Jugendstil", "Art Nouveau"), ("Kubismus", "Cubism"), ("Une estampe japonaise", "Ukiyo-e"),
                   ("Une miniature persane", "Persian miniature"), ("絵本のイラスト", "Children's book illustration"),
                   ("ゴッホ風に", "Van Gogh"), ("Impresionismo", "Impressionism"), ("Kubizm", "Cubism"),
                   ("Puntillismo", "Pointillism"), ("Azulejos portugueses", "Azulejo"), ("Fais-en un vitrail", "Stained glass"),
                   ("Arte pop", "Pop art"), ("Mondriaan", "Mondrian"), ("莫奈的睡莲", "Monet"), ("Make it a Kandinski", "Kandinsky"),
                   ("Like Rembrant", "Rembrandt"), ("Estilo barroco", "Baroque"), ("Miniatura india tradicional", "Indian miniature"))
UNKNOWN_NAMES = ("Make it a Zorblax painting", "In the style of Quendrick Vallimor", "Like Hundertwasser",
                 "A Brakkenfeld print")
LEXICON_SHEET_GROUPS = ("impressionism", "modernism", "japanese", "miniatures", "crafts", "old_masters", "popular", "world")



@contextmanager
def embedder(name: str):
    old = os.environ.get("LAPIG_TEXT_EMBEDDER")
    os.environ["LAPIG_TEXT_EMBEDDER"] = name
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("LAPIG_TEXT_EMBEDDER", None)
        else:
            os.environ["LAPIG_TEXT_EMBEDDER"] = old


def signature(info: dict) -> tuple:
    """The mapped look: the medium (best style or look) and the mood."""
    u = info.get("understood", {})
    medium = u.get("medium") or {}
    top = medium.get("look") or (medium.get("styles") or [[None]])[0][0]
    return top, u.get("mood")


def render(backend, surfaces, prompt):
    looks, info = [], None
    for img in surfaces.values():
        x = torch.from_numpy(img).permute(2, 0, 1)[None].float()
        y = backend.stylize(x, prompt, seed=0)
        looks.append(y[0].permute(1, 2, 0).clamp(0, 1).numpy())
        info = backend.describe()
    return looks, info


def run(args) -> dict:
    t0 = time.perf_counter()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    size = 192
    surfaces = sheet_surfaces(size)
    new, old = get_backend("styletransfer", internal_size=384), get_backend("styletransfer", internal_size=384,
                                                                           looks=False)
    rows, by_prompt = [], {}
    t_new = t_old = 0.0
    for prompt, group, expect in PROMPTS:
        t = time.perf_counter()
        looks_new, info = render(new, surfaces, prompt)
        t_new += time.perf_counter() - t
        with embedder("minilm"):
            t = time.perf_counter()
            looks_old, info_old = render(old, surfaces, prompt)
            t_old += time.perf_counter() - t
        row = {"prompt": prompt, "group": group, "understood": info["understood_line"],
               "looks": info["looks"], "styles": info["styles"][:2], "old_styles": info_old["styles"][:2],
               "signature": list(signature(info))}
        for label, looks in (("new", looks_new), ("old", looks_old)):
            if "colours" in expect:
                present = []
                for name in expect["colours"]:
                    rgb = colour_by_name(name).rgb
                    present.append(all(colour_present(rgb, dominant_palette(img)) for img in looks))
                row[f"colours_present_{label}"] = present
                row[f"colour_ok_{label}"] = all(present)
            if "mood" in expect:
                deltas = [float((img @ np.array([0.299, 0.587, 0.114])).mean() -
                                (s @ np.array([0.299, 0.587, 0.114])).mean())
                          for img, s in zip(looks, surfaces.values())]
                ok = all(d < -0.03 for d in deltas) if expect["mood"] == "dark" else all(d > 0.03 for d in deltas)
                row[f"luminance_change_{label}"] = [round(d, 3) for d in deltas]
                row[f"mood_ok_{label}"] = ok
        if "colours" in expect:
            parsed = [c["name"] for c in info["understood"]["colours"]]
            row["colours_parsed"] = parsed
        by_prompt[prompt] = (row, looks_new, looks_old, info_old)
        rows.append(row)
    # multilingual agreement: the English counterpart's mapped look
    sig = {p: tuple(r["signature"]) for p, (r, *_) in by_prompt.items()}
    agree = []
    for prompt, group, expect in PROMPTS:
        if "english" in expect:
            ok = sig[prompt] == sig[expect["english"]]
            by_prompt[prompt][0]["agrees_with_english"] = ok
            by_prompt[prompt][0]["english_signature"] = list(sig[expect["english"]])
            agree.append(ok)
    agree_old = []
    for prompt, group, expect in PROMPTS:
        if "english" in expect:
            a = [n for n, _ in by_prompt[prompt][3]["styles"][:1]]
            b = [n for n, _ in by_prompt[expect["english"]][3]["styles"][:1]]
            agree_old.append(a == b)

    def share(key):
        vals = [r[key] for r in rows if key in r]
        return round(sum(vals) / len(vals), 3) if vals else None

    sheets = []
    for group in dict.fromkeys(g for _, g, _ in PROMPTS):
        tiles, labels = [], []
        for prompt, g, _ in PROMPTS:
            if g != group:
                continue
            row, looks_new, looks_old, _ = by_prompt[prompt]
            tiles += looks_new + looks_old
            short = prompt[:30]
            labels += [f"{short}", "  (new, sakura)", "  old: " + (row["old_styles"][0][0] if row["old_styles"] else ""),
                       "  (old, sakura)"]
        path = os.path.join(out, f"sheet_{group.replace(' ', '_')}.png")
        write_png(path, labelled_grid(tiles, labels, columns=8, cell=170,
                                      title=f"bench prompts: {group} (each prompt: new scene, new sakura, "
                                            "old scene, old sakura)"))
        sheets.append(path)
    inputs = os.path.join(out, "inputs.png")
    write_png(inputs, labelled_grid(list(surfaces.values()), list(surfaces), columns=2, cell=170))
    summary = {
        "colour_adherence": share("colour_ok_new"), "colour_adherence_old": share("colour_ok_old"),
        "mood_adherence": share("mood_ok_new"), "mood_adherence_old": share("mood_ok_old"),
        "multilingual_agreement": round(sum(agree) / len(agree), 3),
        "multilingual_agreement_old": round(sum(agree_old) / len(agree_old), 3),
        "prompts": len(PROMPTS), "colour_prompts": sum("colours" in e for _, _, e in PROMPTS),
        "mood_prompts": sum("mood" in e for _, _, e in PROMPTS),
        "non_english_prompts": sum("english" in e for _, _, e in PROMPTS),
        "seconds_per_prompt_new": round(t_new / len(PROMPTS) / len(surfaces), 3),
        "seconds_per_prompt_old": round(t_old / len(PROMPTS) / len(surfaces), 3),
        "size": size, "rows": rows, "sheets": sheets + [inputs],
        "embedder": rows[0] and new.describe()["understood"]["embedder"],
        "machine": platform.processor() or platform.machine(), "cpu_threads": torch.get_num_threads(),
    }
    summary.update(run_named(new, surfaces, out))
    if getattr(args, "psa_surfaces", 0):
        summary["psa"] = run_psa_check(args, out)
    summary["bench_total_s"] = round(time.perf_counter() - t0, 1)
    return summary


def _ascii(text: str) -> str:
    """A label the sheet's font can draw (Cézanne -> Cezanne)."""
    import unicodedata

    return unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode()


def run_named(backend, surfaces, out) -> dict:
    """The named looks of the art lexicon: the paper's prompts, painter adherence, names in other
    languages, unknown names, and a sheet per family."""
    from ...lapig_core.lgst import art_lexicon
    from ...lapig_core.lgst.prompt_plan import plan_prompt
    from .painter_checks import PAINTER_CHECKS, PAPER_ENTRIES, PAPER_PROMPTS, check_image

    t0 = time.perf_counter()
    paper = []
    for prompt, expected in zip(PAPER_PROMPTS, PAPER_ENTRIES):
        plan = plan_prompt(prompt)
        name = plan.entry.name if plan.entry else None
        paper.append({"prompt": prompt, "entry": name, "expected": expected, "unmatched": plan.unmatched,
                      "understood": plan.summary(), "ok": name == expected and not plan.unmatched})
    painters, misses, tiles, labels = [], [], [], []
    for name, prompt, checks in PAINTER_CHECKS:
        looks, info = render(backend, surfaces, prompt)
        entry = (info["understood"].get("entry") or {}).get("name")
        per_surface = [check_image(checks, img) for img in looks]
        ok = entry == name and all(good for good, _ in per_surface)
        row = {"entry": name, "prompt": prompt, "found": entry, "ok": ok, "looks": info["looks"],
               "understood": info["understood_line"],
               "checks": {s: why for s, (_, why) in zip(surfaces, per_surface)}}
        painters.append(row)
        if not ok:
            misses.append({"entry": name, "found": entry,
                           "failed": {s: why for s, (good, why) in zip(surfaces, per_surface) if not good}})
        tiles += looks
        labels += [f"{_ascii(name)[:22]}" + ("" if ok else " (miss)"), "  sakura"]
    path = os.path.join(out, "painter_checks.png")
    write_png(path, labelled_grid(tiles, labels, columns=8, cell=170,
                                  title="bench prompts: named entries with a written palette check (miss = check failed)"))
    sheets = [path]
    elsewhere = []
    for prompt, expected in NAMES_ELSEWHERE:
        plan = plan_prompt(prompt)
        found = plan.entry.name if plan.entry else None
        elsewhere.append({"prompt": prompt, "expected": expected, "found": found, "by": plan.entry_how,
                          "ok": found == expected})
    unknown = []
    for prompt in UNKNOWN_NAMES:
        plan = plan_prompt(prompt)
        said = [m for m in plan.unmatched if "nearest names: " in m and len(m.split("nearest names: ")[1].split(", ")) == 3]
        unknown.append({"prompt": prompt, "entry": plan.entry.name if plan.entry else None, "told": said,
                        "ok": plan.entry is None and bool(said)})
    t_checks = time.perf_counter() - t0
    for group in LEXICON_SHEET_GROUPS:
        tiles, labels = [], []
        for e in art_lexicon.ENTRIES:
            if e.group != group:
                continue
            looks, _ = render(backend, surfaces, e.name)
            tiles += looks
            labels += [_ascii(e.name)[:24], f"  {e.medium()[:22]}"]
        path = os.path.join(out, f"lexicon_{group}.png")
        write_png(path, labelled_grid(tiles, labels, columns=8, cell=170,
                                      title=f"art lexicon: {group} (each entry: scene, sakura; label: its medium)"))
        sheets.append(path)
    share = lambda rows: round(sum(r["ok"] for r in rows) / len(rows), 3)
    groups = {}
    for e in art_lexicon.ENTRIES:
        groups[e.group] = groups.get(e.group, 0) + 1
    return {"paper_prompts_understood": share(paper), "painter_adherence": share(painters),
            "painter_entries": len(painters), "painter_misses": misses,
            "names_other_languages": share(elsewhere), "unknown_names_told": share(unknown),
            "lexicon_entries": len(art_lexicon.ENTRIES), "lexicon_groups": groups,
            "paper_rows": paper, "painter_rows": painters, "elsewhere_rows": elsewhere, "unknown_rows": unknown,
            "named_checks_s": round(t_checks, 1), "lexicon_sheets": sheets}


def run_psa_check(args, out) -> dict:
    """Table 1 on --psa-surfaces surfaces x the first --prompts PSA_PROMPTS (PSA_NAMED_PROMPTS with
    --psa-named), through bench_psa."""
    from . import bench_psa

    prompts = (PSA_NAMED_PROMPTS if getattr(args, "psa_named", False) else PSA_PROMPTS)[:args.prompts]
    rows, sheets = [], []
    for name in bench_psa.SURFACES[:args.psa_surfaces]:
        r, sheet, _ = bench_psa.run_surface(name, args, os.path.join(out, "psa"), args.backend, prompts, 0)
        rows += r
        sheets.append(sheet)
        for row in r:  # each surface as it is done (the whole check takes long on a loaded machine)
            print("psa row:", {k: (round(v, 4) if isinstance(v, float) else v) for k, v in row.items()}, flush=True)
    with_psa = [r for r in rows if r["variant"] == "all"]
    without = [r for r in rows if r["variant"] == "without"]
    mean = lambda vs, k: round(float(np.mean([v[k] for v in vs])), 4)
    return {"gain_db": round(mean(with_psa, "psnr") - mean(without, "psnr"), 3),
            "with_psa_psnr": mean(with_psa, "psnr"), "without_psa_psnr": mean(without, "psnr"),
            "style_retention_ssim": mean(with_psa, "retention_ssim"),
            "style_retention_structure": mean(with_psa, "retention_structure"),
            "psa_seconds_mean": mean(with_psa, "seconds"),
            "psa_seconds_max": round(max(r["seconds"] for r in with_psa), 2),
            "per_surface_gain_db": {s: round(mean([r for r in with_psa if r["surface"] == s], "psnr") -
                                             mean([r for r in without if r["surface"] == s], "psnr"), 3)
                                    for s in dict.fromkeys(r["surface"] for r in rows)},
            "prompts": list(prompts), "sheets": sheets}
