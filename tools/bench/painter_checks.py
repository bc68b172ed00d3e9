"""What a named look must carry: the palette property of each named entry, written down from the facts of
the work (art_lexicon.toml) before any of these looks was rendered (issue 30). `bench prompts` renders
each prompt on the two sheet surfaces and counts an entry as followed when every check holds on both.

Checks read an (H,W,3) image in [0,1]:
  hues(lo, hi, share, chroma): at least `share` of the pixels have a hue (HSV degrees; lo > hi wraps
      through red) in [lo, hi] and a chroma (max - min of RGB) of at least `chroma`;
  dark(share, below): at least `share` of the pixels have luminance below `below`;
  light(share, above): ... above `above`;
  mean_lum(lo, hi), mean_chroma(lo, hi): the mean luminance / chroma in [lo, hi];
  present(names, n): at least n of the named colours are in the look's dominant palette (k-means,
      as the colour figure counts them);
  hue_families(n, share): at least n of the six 60-degree hue sectors (centred on red, yellow, green,
      cyan, blue, magenta) each hold `share` of the pixels with chroma >= 0.3.
"""
from __future__ import annotations

import numpy as np

LUMA = np.array([0.299, 0.587, 0.114])

# the primaries of Mondrian, Bauhaus and comics: red, yellow and blue at full strength
PRIMARIES = ((345, 15), (40, 65), (205, 250))


def _hue_chroma(img):
    mx, mn = img.max(-1), img.min(-1)
    chroma = mx - mn
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    safe = np.where(chroma > 1e-6, chroma, 1.0)
    h = np.where(mx == r, ((g - b) / safe) % 6, np.where(mx == g, (b - r) / safe + 2, (r - g) / safe + 4))
    return (h * 60.0) % 360.0, chroma


def _in_hue(h, lo, hi):
    return (h >= lo) & (h <= hi) if lo <= hi else (h >= lo) | (h <= hi)


def hues(lo, hi, share, chroma=0.25):
    def check(img):
        h, c = _hue_chroma(img)
        got = float((_in_hue(h, lo, hi) & (c >= chroma)).mean())
        return got >= share, f"hue {lo}-{hi} chroma>={chroma}: {got:.2f} (>= {share})"
    return check


def primaries(share, chroma=0.5):
    def check(img):
        h, c = _hue_chroma(img)
        mask = np.zeros(h.shape, bool)
        for lo, hi in PRIMARIES:
            mask |= _in_hue(h, lo, hi)
        got = float((mask & (c >= chroma)).mean())
        return got >= share, f"saturated red/yellow/blue: {got:.2f} (>= {share})"
    return check


def dark(share, below=0.18):
    def check(img):
        got = float(((img @ LUMA) < below).mean())
        return got >= share, f"luminance<{below}: {got:.2f} (>= {share})"
    return check


def light(share, above=0.8):
    def check(img):
        got = float(((img @ LUMA) > above).mean())
        return got >= share, f"luminance>{above}: {got:.2f} (>= {share})"
    return check


def mean_lum(lo=0.0, hi=1.0):
    def check(img):
        got = float((img @ LUMA).mean())
        return lo <= got <= hi, f"mean luminance {got:.2f} (in {lo}-{hi})"
    return check


def mean_chroma(lo=0.0, hi=1.0):
    def check(img):
        got = float(_hue_chroma(img)[1].mean())
        return lo <= got <= hi, f"mean chroma {got:.2f} (in {lo}-{hi})"
    return check


def present(names, n):
    def check(img):
        from .palette_measure import colour_present, dominant_palette
        from ...lapig_core.lgst.colours import colour_by_name

        palette = dominant_palette(img)
        found = [name for name in names if colour_present(colour_by_name(name).rgb, palette)]
        return len(found) >= n, f"{len(found)} of {list(names)} present ({', '.join(found) or 'none'}; >= {n})"
    return check


def hue_families(n, share=0.03):
    def check(img):
        h, c = _hue_chroma(img)
        strong = c >= 0.3
        sectors = [float((strong & _in_hue(h, (k * 60 - 30) % 360, (k * 60 + 30) % 360)).mean()) for k in range(6)]
        got = sum(s >= share for s in sectors)
        return got >= n, f"{got} hue families of >= {share} (>= {n})"
    return check


GOLD = (35, 65)
BLUE = (195, 250)

# (entry, prompt, checks): written from the entries' facts before rendering them
PAINTER_CHECKS = (
    # -- Impressionism and after
    ("Monet", "Paint it like Monet",
     [present(["lilac", "pale blue", "sage green", "pink", "cream"], 2), mean_lum(0.5), dark(0.0)]),
    ("Renoir", "A Renoir", [present(["rose pink", "peach", "cornflower blue", "sage green", "cream"], 2),
                            mean_lum(0.45)]),
    ("Impressionism", "An impressionist painting", [mean_lum(0.45)]),
    ("Seurat", "Make it a Seurat", [hue_families(3), present(["orange", "cornflower blue", "emerald",
                                                              "golden yellow", "lilac", "cream"], 3)]),
    ("Signac", "In the manner of Signac", [hue_families(4)]),
    ("Pointillism", "Pointillism", [hue_families(3)]),
    ("Van Gogh", "Render it in the style of a Van Gogh oil painting",
     [hues(*BLUE, 0.2), hues(40, 65, 0.08)]),
    ("Cézanne", "Like Cezanne", [present(["ochre", "sage green", "cerulean", "terracotta", "cream"], 2)]),
    ("Gauguin", "A Gauguin", [present(["orange", "magenta pink", "emerald", "ochre", "prussian blue"], 3)]),
    ("Turner", "Make it a Turner", [hues(*GOLD, 0.3, chroma=0.2), mean_lum(0.5)]),
    # -- modernism
    ("Klimt", "Make it a Klimt", [hues(*GOLD, 0.25)]),
    ("Mondrian", "Mondrian", [primaries(0.30), dark(0.03, below=0.15)]),
    ("Rothko", "A Rothko", [hues(345, 40, 0.5, chroma=0.3)]),
    ("Matisse cut-outs", "Matisse cut-outs", [hues(215, 255, 0.15, chroma=0.4), light(0.2, above=0.85)]),
    ("Kandinsky", "Make it a Kandinsky", [hue_families(4)]),
    ("Miró", "Make it a Miro painting",
     [present(["vermilion", "golden yellow", "cobalt blue", "black"], 3)]),
    ("Modigliani", "Make it a Modigliani painting", [hues(10, 45, 0.3, chroma=0.2)]),
    ("Munch", "Like Munch's Scream", [hues(0, 40, 0.2), hues(*BLUE, 0.1, chroma=0.15)]),
    ("Picasso's Blue Period", "Picasso's blue period", [hues(190, 250, 0.6, chroma=0.1)]),
    ("Cubism", "Cubism", [mean_chroma(hi=0.35), hues(20, 60, 0.25, chroma=0.1)]),
    ("Pop art", "Pop art", [hues(0, 360, 0.35, chroma=0.5)]),
    ("Warhol", "Make it a Warhol", [hues(0, 360, 0.4, chroma=0.5)]),
    ("Lichtenstein", "Like Lichtenstein", [primaries(0.25), dark(0.03, below=0.15)]),
    ("Bauhaus", "A Bauhaus poster", [primaries(0.25)]),
    ("Art Deco", "Art Deco", [hues(*GOLD, 0.1), dark(0.15)]),
    ("Art Nouveau", "Art Nouveau", [present(["sage green", "olive green", "ochre", "gold", "dusty pink", "cream"], 3)]),
    ("Fauvism", "Fauvism", [hues(0, 360, 0.4, chroma=0.45)]),
    ("Expressionism", "Expressionism", [hues(0, 360, 0.35, chroma=0.4)]),
    ("Frida Kahlo", "Like Frida Kahlo", [present(["emerald", "crimson", "golden yellow", "cobalt blue", "terracotta"], 3)]),
    # -- Japanese prints and East Asian painting
    ("Hokusai", "Hokusai's great wave", [hues(195, 235, 0.2, chroma=0.2), light(0.1, above=0.75)]),
    ("Hiroshige", "A Hiroshige print", [hues(190, 240, 0.15, chroma=0.2),
                                        present(["prussian blue", "sage green", "vermilion", "cream", "slate grey"], 2)]),
    ("Ukiyo-e", "Ukiyo-e", [present(["prussian blue", "vermilion", "ochre", "sage green", "cream", "black"], 3)]),
    ("Sumi-e", "A sumi-e ink painting", [mean_chroma(hi=0.08)]),
    ("Rinpa", "A Rinpa gold screen", [hues(*GOLD, 0.2)]),
    # -- miniatures
    ("Indian miniature", "Imagine it as a traditional Indian miniature painting",
     [present(["vermilion", "saffron", "emerald", "lapis", "gold", "cream"], 3), hues(0, 60, 0.2)]),
    ("Mughal miniature", "A Mughal miniature", [present(["gold", "emerald", "vermilion", "lapis", "pale goldenrod", "cream"], 3),
                                                hues(*GOLD, 0.05)]),
    ("Persian miniature", "A Persian miniature", [hues(170, 230, 0.15),
                                                  present(["turquoise", "lapis", "gold", "vermilion", "emerald", "cream"], 3)]),
    ("Illuminated manuscript", "An illuminated manuscript", [present(["ultramarine", "vermilion", "gold", "emerald", "parchment"], 3)]),
    ("Byzantine icon", "A Byzantine icon", [hues(*GOLD, 0.25)]),
    # -- crafts
    ("Stained glass", "Make it a stained glass artwork",
     [hues(0, 360, 0.4, chroma=0.45), dark(0.05, below=0.12)]),
    ("Azulejo", "Azulejo tiles", [hues(200, 240, 0.25), light(0.25)]),
    ("Delftware", "Delft blue", [hues(200, 240, 0.25), light(0.25)]),
    ("Blueprint", "A blueprint", [hues(195, 230, 0.5, chroma=0.3), light(0.02, above=0.75)]),
    ("Cyanotype", "A cyanotype", [hues(190, 240, 0.6, chroma=0.15)]),
    ("Batik", "Batik", [present(["indigo", "chocolate brown", "sepia", "cream", "rust"], 3)]),
    ("Tapestry", "A medieval tapestry", [present(["crimson", "navy", "ochre", "sage green", "cream"], 3)]),
    ("Claymation", "Make it a Claymation", [hues(0, 360, 0.4, chroma=0.35)]),
    ("Pixel art", "Transform it into a 1980s retro pixel art graphic", [hue_families(3)]),
    ("Children's book illustration", "Render it as a whimsical children's book illustration",
     [mean_lum(0.5), present(["peach", "sky blue", "sage green", "golden yellow", "coral", "cream"], 3)]),
    # -- old masters
    ("Rembrandt", "Like Rembrandt", [dark(0.3, below=0.2), hues(20, 55, 0.15, chroma=0.15)]),
    ("Caravaggio", "Caravaggio", [dark(0.4, below=0.2)]),
    ("Vermeer", "A Vermeer", [hues(215, 250, 0.05), hues(45, 65, 0.05)]),
    ("Leonardo da Vinci", "Leonardo's sfumato", [mean_chroma(hi=0.3), hues(30, 90, 0.3, chroma=0.05)]),
    ("Dürer", "A Dürer engraving", [mean_chroma(hi=0.06)]),
    # -- popular
    ("Film noir", "Film noir", [mean_chroma(hi=0.06), dark(0.25)]),
    ("Synthwave", "Synthwave", [dark(0.4, below=0.2)]),
    ("Steampunk", "Steampunk", [hues(20, 50, 0.4, chroma=0.15)]),
)

# the paper's nine prompts (NOTES.md section 1), each must map to an entry with no unmatched name
PAPER_PROMPTS = ("Make it a stained glass artwork", "Make it a Claymation", "Make it a Miro painting",
                 "Turn into an oil pastel drawing", "Make it a Modigliani painting",
                 "Transform it into a 1980s retro pixel art graphic",
                 "Render it as a whimsical children's book illustration",
                 "Render it in the style of a Van Gogh oil painting",
                 "Imagine it as a traditional Indian miniature painting")
PAPER_ENTRIES = ("Stained glass", "Claymation", "Miró", "Oil pastel", "Modigliani", "Pixel art",
                 "Children's book illustration", "Van Gogh", "Indian miniature")


def check_image(checks, img) -> tuple[bool, list[str]]:
    results = [c(np.clip(img, 0, 1)) for c in checks]
    return all(ok for ok, _ in results), [why for _, why in results]

