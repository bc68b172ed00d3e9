"""The look library: every look with its role, what it looks like, and the tags a prompt is matched with.

Roles: a *medium* replaces the neural style (the prompt mapper picks the best medium among the 26
styles and these); a *mood* grades the result; a *texture* is laid over it; the *palette* comes from
the colours the prompt names (colours.py) and is not matched by words. Descriptions were written
after looking at each look on the test surfaces (out/looks/looks_sheet.png, tools/bench/look_sheet.py).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from . import crafts, geometric, glow, grading, graphic, painterly, palette, texture
from .stage import Stage


@dataclass(frozen=True)
class Look:
    name: str
    role: str                      # medium / mood / texture / palette
    description: str
    tags: tuple[str, ...]
    make: Callable[..., Stage]     # make(colours: list[rgb] | None) -> Stage
    uses_colours: bool = False     # takes the named colours itself (no separate palette stage)

    def text(self) -> str:
        return f"{self.name.replace('_', ' ')}. {self.description} Style: {', '.join(self.tags)}."


def _mood(name):
    return lambda colours=None: grading.grade_stage(name)


LOOKS: tuple[Look, ...] = (
    # -- media ----------------------------------------------------------------------------------------
    Look("posterise", "medium",
         "The image's own colours cut into three flat steps per channel with crisp borders between them, "
         "more saturated; like a screen-printed poster. On an image already made of flat areas it changes "
         "little.",
         ("posterize", "posterized", "flat colours", "screen print", "poster", "silkscreen", "graphic"),
         lambda colours=None: graphic.posterise_stage()),
    Look("line_art", "medium",
         "Dark ink outlines traced along every edge of the image on cream paper, with only a faint wash "
         "of its colour; like a pen line drawing or a colouring-book page.",
         ("line art", "line drawing", "outline", "pen and ink", "ink sketch", "contour drawing",
          "colouring book", "technical drawing"),
         graphic.line_art_stage, uses_colours=True),
    Look("comic_outlines", "medium",
         "Three flat, strongly saturated tones per channel with thick black outlines around the shapes; "
         "like a cartoon cel or a comic-book panel.",
         ("comic book", "cartoon", "cel shading", "anime", "graphic novel", "bold outlines", "toon"),
         lambda colours=None: graphic.comic_stage()),
    Look("woodblock", "medium",
         "A few flat inks (indigo, vermilion, ochre on cream, or the colours named) in bands of tone, "
         "dark key-block outlines and faint streaks of wood grain; like a Japanese ukiyo-e woodblock "
         "print or a linocut.",
         ("woodblock print", "woodcut", "ukiyo-e", "Japanese print", "linocut", "relief print", "Hokusai",
          "flat colour"),
         graphic.woodblock_stage, uses_colours=True),
    Look("halftone", "medium",
         "The image rebuilt from round dots on a regular grid, big dots in the shadows and tiny ones in "
         "the light, on pale paper; like a newspaper photo or a pop-art print.",
         ("halftone", "dots", "newspaper print", "Ben-Day dots", "pop art", "Lichtenstein", "print screen",
          "dotted"),
         graphic.halftone_stage, uses_colours=True),
    Look("mosaic_tiles", "medium",
         "Square tiles, each one flat colour of the image with a slightly different shade, set in light "
         "grout lines; like a Roman tesserae mosaic or a tiled wall.",
         ("mosaic", "tiles", "tesserae", "tiled", "Roman mosaic", "Byzantine", "ceramic tiles", "pixel grid"),
         lambda colours=None: graphic.mosaic_stage()),
    Look("neon_glow", "medium",
         "The image darkened almost to black, its edges drawn as glowing neon tubes (magenta, cyan and "
         "green, or the colours named) with a soft halo of light; like neon signs at night or synthwave.",
         ("neon", "neon lights", "glowing lines", "synthwave", "cyberpunk", "retrowave", "night club",
          "electric glow"),
         glow.neon_stage, uses_colours=True),
    Look("soft_glow", "medium",
         "The image's own colours with a wide soft bloom of light spreading from its bright parts; "
         "dreamy and hazy, like a glowing lens or an ethereal photograph.",
         ("glow", "bloom", "dreamy", "ethereal", "soft focus", "glowing", "luminous", "hazy light"),
         lambda colours=None: glow.bloom_stage()),
    Look("watercolour_wash", "medium",
         "The image's colours as a light, slightly blurred transparent wash, with pigment pooling darker "
         "along the rims of each area and a grainy paper showing through; like a loose watercolour.",
         ("watercolour", "watercolor", "aquarelle", "wash", "wet paint", "transparent paint", "pigment"),
         lambda colours=None: texture.watercolour_stage()),
    Look("duotone", "medium",
         "Two inks only: deep navy in the shadows and warm peach in the light (or the colours named), "
         "smoothly graded between them; like a two-colour print or a duotone photo.",
         ("duotone", "two-tone", "two colours", "gradient map", "monochrome print", "split tone"),
         lambda colours=None: palette.gradient_map_stage(colours or [(0.1, 0.12, 0.3), (1.0, 0.8, 0.62)],
                                                         look="duotone", role="medium", strength=0.95,
                                                         plateau=None),
         uses_colours=True),
    Look("modelling_clay", "medium",
         "Smooth rounded lumps of a few saturated colours with soft light from the top left and a faint "
         "sheen on their rims, the detail melted away; like plasticine figures in a stop-motion film.",
         ("claymation", "clay", "plasticine", "modelling clay", "stop motion", "clay animation", "Aardman"),
         texture.clay_stage, uses_colours=True),
    # -- named looks of the art lexicon (issue 30) -----------------------------------------------------
    Look("broken_strokes", "medium",
         "Short strokes of a few light colours laid side by side, each stroke one colour of the palette "
         "chosen by the tone under it, so the colours break and shimmer; like an Impressionist painting.",
         ("broken colour", "impressionist brushstrokes", "dabs of colour", "plein air painting"),
         painterly.broken_strokes_stage, uses_colours=True),
    Look("pointillist_dots", "medium",
         "The image rebuilt from small round dots of pure, unmixed colour on a pale ground; neighbouring "
         "dots take neighbouring colours of the palette and mix in the eye; like Seurat.",
         ("pointillism", "pointillist", "dots of pure colour", "divisionism", "Seurat"),
         painterly.pointillist_dots_stage, uses_colours=True),
    Look("colour_fields", "medium",
         "Two or three large soft-edged rectangles of glowing colour stacked on a darker ground, the "
         "image's light and dark breathing faintly through them; like Rothko's colour fields.",
         ("colour field", "color field", "Rothko", "soft rectangles", "stacked rectangles"),
         painterly.colour_fields_stage, uses_colours=True),
    Look("primary_grid", "medium",
         "Straight black lines divide the image into rectangles, most of them white, some flat red, "
         "yellow or blue; like Mondrian and De Stijl.",
         ("Mondrian", "De Stijl", "primary colour grid", "black grid lines", "neoplasticism"),
         painterly.primary_grid_stage, uses_colours=True),
    Look("gold_leaf", "medium",
         "The image's light parts turned into beaten gold leaf stamped with rings, squares and dots; its "
         "dark parts flat paint in the other colours; like Klimt's golden phase or an icon.",
         ("gold leaf", "gilded", "Klimt", "golden ornament", "icon gold ground"),
         painterly.gold_leaf_stage, uses_colours=True),
    Look("chiaroscuro", "medium",
         "One warm light falls on part of the image and the rest sinks into near-black, tones mapped "
         "through umber, ochre and gold; like Rembrandt or Caravaggio.",
         ("chiaroscuro", "tenebrism", "Rembrandt lighting", "old master", "dramatic light and shadow"),
         painterly.chiaroscuro_stage, uses_colours=True),
    Look("stained_glass", "medium",
         "Irregular pieces of glowing jewel-coloured glass joined by dark lead lines, each piece one "
         "colour, brighter at its heart; like a church window.",
         ("stained glass window", "leaded glass", "lead came", "cathedral window", "jewel glass"),
         painterly.stained_glass_stage, uses_colours=True),
    Look("cubist_facets", "medium",
         "The image broken into large angular facets, each shaded across itself in a muted palette of "
         "ochre, umber, olive and grey, with thin dark edges; like Cubism.",
         ("cubism", "cubist", "facets", "angular planes", "fractured planes"),
         painterly.cubist_facets_stage, uses_colours=True),
    Look("poured_lines", "medium",
         "Webs of thin dripped and poured lines of black, white and colour laid over the whole image; "
         "like Pollock's drip paintings.",
         ("drip painting", "poured paint", "Pollock", "splatter", "action painting"),
         painterly.poured_lines_stage, uses_colours=True),
    Look("wavy_bands", "medium",
         "Long undulating bands of a few strong colours run through the whole image, bent by its tones, "
         "with streaks along them; like the sky in Munch's Scream.",
         ("wavy bands", "undulating lines", "Munch", "The Scream", "swirling sky"),
         painterly.wavy_bands_stage, uses_colours=True),
    Look("miniature", "medium",
         "Flat opaque colour in a few jewel-like inks inside fine dark outlines, framed by a painted "
         "border with rules and dots; like an Indian or Persian miniature.",
         ("miniature painting", "Indian miniature", "Persian miniature", "Mughal", "decorated border"),
         crafts.miniature_stage, uses_colours=True),
    Look("storybook", "medium",
         "Soft flat colours in gentle outlines with a little unevenness of gouache; friendly and simple, "
         "like a children's picture book.",
         ("children's book", "picture book", "storybook", "gouache illustration", "flat illustration"),
         crafts.storybook_stage, uses_colours=True),
    Look("paper_cutouts", "medium",
         "Large flat shapes in a few strong colours with softly irregular edges on white, no outlines; "
         "like shapes cut from painted paper (Matisse's cut-outs).",
         ("cut-outs", "paper cut-outs", "cut paper", "Matisse cut-outs", "collage shapes"),
         crafts.paper_cutouts_stage, uses_colours=True),
    Look("ben_day", "medium",
         "Flat printed colours with thick black outlines, the lighter tones printed as Ben-Day dots of "
         "their colour on white paper; like Lichtenstein's blown-up comic panels.",
         ("Ben-Day dots", "Lichtenstein", "pop art print", "comic dots"),
         crafts.ben_day_stage, uses_colours=True),
    Look("pixel_art", "medium",
         "Big square pixels, each one colour of a small retro palette, with dark outlines at the edges; "
         "like a 1980s video game.",
         ("pixel art", "8-bit", "16-bit", "pixelated", "retro video game"),
         crafts.pixel_art_stage, uses_colours=True),
    Look("glazed_tiles", "medium",
         "Square glazed tiles with the image painted in cobalt blues on white, a quatrefoil ornament in "
         "each tile, light grout and a gloss; like Portuguese azulejos or Delft tiles.",
         ("azulejo", "Delft tiles", "blue and white tiles", "glazed ceramic tiles", "porcelain blue"),
         crafts.glazed_tiles_stage, uses_colours=True),
    Look("blueprint", "medium",
         "White lines traced along the image's edges on deep Prussian-blue paper with a faint grid; like "
         "an architect's blueprint.",
         ("blueprint", "technical drawing", "engineering drawing", "white lines on blue"),
         crafts.blueprint_stage, uses_colours=True),
    Look("wax_resist", "medium",
         "Flat dyes of indigo and brown on cream with fine crackle veins where the wax broke; like batik "
         "cloth.",
         ("batik", "wax resist", "crackle dye", "dyed cloth"),
         crafts.wax_resist_stage, uses_colours=True),
    Look("woven_threads", "medium",
         "The image as rows of small stitches of coloured thread, each stitch rounded by its shading, "
         "alternate rows offset like a weave; like a tapestry or cross-stitch.",
         ("tapestry weave", "cross-stitch", "woven threads", "needlework", "stitches"),
         crafts.woven_threads_stage, uses_colours=True),
    Look("deco_sunburst", "medium",
         "A sunburst of alternating cream and gold rays fanning from a gold half-sun, the image's dark "
         "shapes flat black, navy or jade with crisp gold outlines, and a band of gold and black chevrons "
         "along the foot; like an Art Deco poster or lobby.",
         ("Art Deco", "sunburst", "chevrons", "streamline moderne", "1920s glamour", "gold and black geometry"),
         geometric.deco_sunburst_stage, uses_colours=True),
    Look("floating_shapes", "medium",
         "Flat black squares, red and blue bars and thin tilted rectangles floating on a white ground, the "
         "image faintly grey beneath them; like Malevich's Suprematism.",
         ("Suprematism", "Malevich", "floating geometric shapes", "black square", "tilted bars on white"),
         geometric.floating_shapes_stage, uses_colours=True),
    Look("circles_and_lines", "medium",
         "Circles of concentric coloured rings with dark halos and black straight lines and arcs crossing "
         "soft washes of many bright colours; like Kandinsky's abstract compositions.",
         ("Kandinsky", "concentric circles", "circles and lines", "abstract composition", "Orphism"),
         geometric.circles_and_lines_stage, uses_colours=True),
    # -- moods ------------------------------------------------------------------------------------------
    Look("night", "mood", "Dark blue moonlight: much darker, cold blue shadows, faded colours.",
         ("night", "nocturnal", "midnight", "moonlit", "moonlight", "at night", "starry sky"), _mood("night")),
    Look("dusk", "mood", "Sunset light: warm orange highlights, violet shadows, a little darker.",
         ("dusk", "sunset", "twilight", "evening", "gloaming"), _mood("dusk")),
    Look("dawn", "mood", "Early morning light: soft pink and peach, slightly lighter and hazy.",
         ("dawn", "sunrise", "morning", "daybreak", "first light"), _mood("dawn")),
    Look("golden_hour", "mood", "Low warm sun: golden yellow highlights and amber shadows.",
         ("golden hour", "golden light", "warm light", "late afternoon"), _mood("golden_hour")),
    Look("bright_sunny", "mood", "Bright daylight: much lighter, open shadows, vivid colours.",
         ("bright", "sunny", "sunlit", "daylight", "summer", "cheerful", "light and airy", "noon"),
         _mood("bright_sunny")),
    Look("dark_moody", "mood", "Dark and gloomy: deep shadows, muted grey colours.",
         ("dark", "moody", "gloomy", "noir", "sombre", "brooding", "gothic", "stormy"), _mood("dark_moody")),
    Look("foggy", "mood", "Fog and mist: a pale grey veil, low contrast, little colour.",
         ("fog", "foggy", "mist", "misty", "haze", "hazy"), _mood("foggy")),
    Look("vintage_faded", "mood", "An old faded print: warm cast, lifted blacks, washed-out colour.",
         ("vintage", "faded", "old photo", "retro", "aged", "nostalgic"), _mood("vintage_faded")),
    Look("neutral_grade", "grade", "The image as it is, under a colour grade PSA can move "
         "(exposure, gamma, saturation, shadow and highlight tints, haze).",
         ("colour grade", "color grading", "grade"), _mood("neutral_grade")),
    Look("wintry", "mood", "Cold winter light: cool blue-white cast, less saturated.",
         ("winter", "wintry", "snowy", "icy", "frosty", "cold light"), _mood("wintry")),
    # -- textures ---------------------------------------------------------------------------------------
    Look("paper_grain", "texture", "Fine fibres and faint blotches of rough paper over the image.",
         ("paper", "on paper", "paper texture", "grain", "grainy", "rough paper"),
         lambda colours=None: texture.paper_stage()),
    Look("canvas_weave", "texture", "The criss-cross weave of a painting canvas pressed into the image.",
         ("canvas", "on canvas", "canvas texture", "linen canvas", "woven"),
         lambda colours=None: texture.canvas_stage()),
)

BY_NAME: dict[str, Look] = {look.name: look for look in LOOKS}
MEDIA = tuple(look for look in LOOKS if look.role == "medium")
MOODS = tuple(look for look in LOOKS if look.role == "mood")
TEXTURES = tuple(look for look in LOOKS if look.role == "texture")


def palette_stage(colours: list, strength: float = 0.85) -> Stage:
    """The named colours as a gradient map over the look (the palette part of a prompt, or a named
    entry's palette at the entry's strength)."""
    return palette.gradient_map_stage(colours, strength=strength)
