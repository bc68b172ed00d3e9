"""What each of the 26 built-in styles of multistyle26.onnx looks like (the model ships no names).

Written by looking at every style, one-hot, on a drawn test scene (sky with clouds, sun, house, tree,
text) and on the sakura surface, run at 2x resolution and area-downsampled (out/lgst/styles_sheet.png).
Descriptions say what the style does, not what it was trained from; artist names appear only where the
resemblance is plain (19: Van Gogh, 21: a little Miro). The prompt mapper embeds these texts, so a
prompt can only be followed as well as some style here really matches it.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Style:
    index: int
    name: str
    description: str
    tags: tuple[str, ...]

    def text(self) -> str:
        """The text the prompt is compared with."""
        return f"{self.name.replace('_', ' ')}. {self.description} Style: {', '.join(self.tags)}."


STYLES: tuple[Style, ...] = (
    Style(0, "ochre_navy_poster",
          "Warm ochre and pale sky-blue areas with dark navy outlines and rough flecked brush dabs in "
          "textured regions; a flat, poster-like expressionist painting.",
          ("painting", "expressionist", "poster", "bold outlines", "ochre", "warm colours")),
    Style(1, "black_ink_cells",
          "Heavy black brush outlines split the image into flat cells of bright yellow, grey and white, "
          "like the lead lines of stained glass or a bold woodcut, but with only those few colours.",
          ("stained glass", "leaded lines", "bold black outlines", "woodcut", "comic", "graphic", "yellow")),
    Style(2, "charcoal_wash",
          "Near-monochrome: a pale grey-blue ground, dark shapes turned almost black, soft smudged "
          "strokes and a touch of peach; like a charcoal or ink-wash drawing.",
          ("charcoal", "ink wash", "black and white", "monochrome", "smudged", "drawing")),
    Style(3, "neon_swirls",
          "Dense glowing ribbons of electric blue, orange and red on near-black cover everything in "
          "swirling strokes; psychedelic and abstract, the content is only half readable.",
          ("psychedelic", "neon", "abstract", "expressionist", "vivid", "swirling strokes")),
    Style(4, "red_ochre_poster",
          "Crimson and warm yellow against pale blue with dark outlines and flecked strokes in "
          "textured regions; a warm, bold poster-like painting.",
          ("painting", "expressionist", "poster", "red", "warm colours", "bold outlines")),
    Style(5, "muted_impasto",
          "Muted brick red, brown and dusty blue with busy short flecks and ridged outlines "
          "everywhere; a textured, earthy oil painting.",
          ("oil painting", "impasto", "impressionist", "earthy", "textured brush strokes")),
    Style(6, "indigo_emboss",
          "Almost monochrome dark indigo with pale blue raised outlines and a pebbly cellular "
          "texture, like an embossed print or a cyanotype.",
          ("monochrome blue", "cyanotype", "embossed", "night", "dark", "printmaking")),
    Style(7, "fauve_primary",
          "Flat, saturated fields of yellow, cobalt blue, rust red and black with dark outlines and "
          "high contrast; a bold fauvist or pop-art poster.",
          ("fauvism", "bold colours", "primary colours", "pop art", "poster", "high contrast")),
    Style(8, "pastel_pencil_white",
          "Bright white paper with magenta, teal and lemon-yellow fills made of fine diagonal "
          "hatching; light and airy, like coloured pencil or oil pastel.",
          ("coloured pencil", "oil pastel", "pastel", "hatching", "sketch", "drawing", "illustration",
           "light", "bright")),
    Style(9, "teal_red_mosaic",
          "Slate grey ground with teal and red forms built from small white-rimmed dots and tiles, "
          "like a mosaic or cross-stitch embroidery.",
          ("mosaic", "tiles", "tesserae", "embroidery", "cross-stitch", "textile", "dotted")),
    Style(10, "rust_woodgrain",
          "Burnt orange, rust and dark brown with a fine rippled diagonal texture like rusted metal "
          "or wood grain; dark shapes become deep brown-black.",
          ("earthy", "rust", "brown", "wood grain", "warm colours", "dark")),
    Style(11, "gold_etching",
          "Golden ochre and cream with dark brown sketchy outlines and a speckled, engraving-like "
          "texture; like an old gilded etching or ink drawing on yellowed paper.",
          ("etching", "engraving", "ink drawing", "gold", "sepia", "vintage")),
    Style(12, "lavender_impressionist",
          "Soft lavender, periwinkle and cream with warm yellow-orange rims and gentle blurred "
          "strokes; a light impressionist painting.",
          ("impressionist", "pastel colours", "lavender", "soft", "dreamy", "painting")),
    Style(13, "green_yellow_fauve",
          "Saturated grass green, lemon yellow, teal and red with lively curving brush strokes and "
          "dark outlines; a vivid fauvist landscape painting.",
          ("fauvism", "expressionist", "vivid", "curving brush strokes", "green", "yellow",
           "oil painting")),
    Style(14, "icy_watercolour",
          "Pale icy blue and white with soft teal shapes and very little texture; washed out and "
          "calm, like a light watercolour wash.",
          ("watercolour", "wash", "pale", "soft", "light blue", "calm")),
    Style(15, "pastel_cells",
          "Pale lavender-pink with forms outlined by thick white and pale cyan lines and small "
          "yellow, teal and pink fills; like chalk pastel, faintly like pale stained glass.",
          ("chalk pastel", "pastel", "line drawing", "sketch", "light")),
    Style(16, "violet_strokes",
          "Blue-violet and purple dominate, with dense short dashes over every surface and orange "
          "and mustard accents; a textured impressionist, almost pointillist look.",
          ("impressionist", "pointillism", "violet", "blue", "short brush strokes", "oil painting")),
    Style(17, "red_blocks",
          "A red ground broken into stacked horizontal bars and rectangles of orange, cream and "
          "blue; a geometric woven or brick pattern that hides most of the content.",
          ("geometric", "abstract", "rectangles", "blocky", "woven textile", "bricks", "pattern")),
    Style(18, "sepia_ink",
          "Tan and cream with brown dry-brush line strokes, near-monochrome sepia; like a pen-and-ink "
          "or sepia wash drawing on tan paper.",
          ("sepia", "ink drawing", "pen and ink", "dry brush", "monochrome", "vintage", "drawing")),
    Style(19, "starry_blue_yellow",
          "Deep cobalt blue and bright yellow with short swirling curved brush strokes everywhere; "
          "strongly reminiscent of Van Gogh's Starry Night.",
          ("Van Gogh", "Starry Night", "post-impressionist", "swirling brush strokes", "oil painting",
           "impasto", "blue and yellow")),
    Style(20, "crimson_fire",
          "Almost monochrome crimson and orange with dark red shapes and short fiery strokes; hot "
          "and dramatic.",
          ("red", "monochrome", "fiery", "dramatic", "expressionist")),
    Style(21, "black_squiggles",
          "A pale blue and cream ground with bold black calligraphic squiggles and blobs and small "
          "red and yellow accents; playful, a little like Miro or a cartoon line drawing.",
          ("Miro", "bold black lines", "calligraphic", "playful", "cartoon", "comic", "whimsical")),
    Style(22, "slate_branches",
          "Slate blue-grey and periwinkle with cream outlines, red accents and dark branching "
          "strokes; a cool, muted modernist painting.",
          ("cool colours", "blue-grey", "muted", "modernist", "painting")),
    Style(23, "smooth_dusk",
          "Smooth, almost textureless soft shapes in dark green-grey, pale blue, cream and maroon "
          "with soft rounded shading; keeps the input's structure best, like a simple matte gouache.",
          ("smooth", "soft", "minimal texture", "gouache", "matte", "muted", "calm")),
    Style(24, "blue_cream_print",
          "Two-tone cream and slate blue with a crackled, pebbly texture and thin cyan rims; like a "
          "blue-and-white print or a crackle-glazed ceramic.",
          ("two-tone", "blue and white", "printmaking", "crackle glaze", "ceramic")),
    Style(25, "tapestry_mesh",
          "Grey-blue with orange, brown and cream woven into a dense wiggly mesh with glowing rims; "
          "like a tapestry or a busy embroidered textile.",
          ("tapestry", "textile", "woven", "dense texture", "embroidery")),
)

NAMES: tuple[str, ...] = tuple(s.name for s in STYLES)
BY_NAME: dict[str, Style] = {s.name: s for s in STYLES}
assert [s.index for s in STYLES] == list(range(26))
