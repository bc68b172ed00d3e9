"""Colour names -> sRGB, as data: the CSS Color Module Level 4 / X11 named colours, plus common
painters' and everyday names the CSS list lacks (sepia, ochre, vermilion, ...), plus basic colour words
of a few other languages.

Colour names and their sRGB values are facts (the CSS list is a public specification); the extra
entries are written here with the value each name usually stands for. Keys are lower case with single
spaces between words; the parser (colours.py) also accepts them written as one word ("darkslategray").
"""
from __future__ import annotations

CSS_COLOURS: dict[str, str] = {
    "alice blue": "#f0f8ff", "antique white": "#faebd7", "aqua": "#00ffff", "aquamarine": "#7fffd4",
    "azure": "#f0ffff", "beige": "#f5f5dc", "bisque": "#ffe4c4", "black": "#000000",
    "blanched almond": "#ffebcd", "blue": "#0000ff", "blue violet": "#8a2be2", "brown": "#a52a2a",
    "burlywood": "#deb887", "cadet blue": "#5f9ea0", "chartreuse": "#7fff00", "chocolate": "#d2691e",
    "coral": "#ff7f50", "cornflower blue": "#6495ed", "cornsilk": "#fff8dc", "crimson": "#dc143c",
    "cyan": "#00ffff", "dark blue": "#00008b", "dark cyan": "#008b8b", "dark goldenrod": "#b8860b",
    "dark gray": "#a9a9a9", "dark green": "#006400", "dark grey": "#a9a9a9", "dark khaki": "#bdb76b",
    "dark magenta": "#8b008b", "dark olive green": "#556b2f", "dark orange": "#ff8c00",
    "dark orchid": "#9932cc", "dark red": "#8b0000", "dark salmon": "#e9967a", "dark sea green": "#8fbc8f",
    "dark slate blue": "#483d8b", "dark slate gray": "#2f4f4f", "dark slate grey": "#2f4f4f",
    "dark turquoise": "#00ced1", "dark violet": "#9400d3", "deep pink": "#ff1493",
    "deep sky blue": "#00bfff", "dim gray": "#696969", "dim grey": "#696969", "dodger blue": "#1e90ff",
    "firebrick": "#b22222", "floral white": "#fffaf0", "forest green": "#228b22", "fuchsia": "#ff00ff",
    "gainsboro": "#dcdcdc", "ghost white": "#f8f8ff", "gold": "#ffd700", "goldenrod": "#daa520",
    "gray": "#808080", "grey": "#808080", "green": "#008000", "green yellow": "#adff2f",
    "honeydew": "#f0fff0", "hot pink": "#ff69b4", "indian red": "#cd5c5c", "indigo": "#4b0082",
    "ivory": "#fffff0", "khaki": "#f0e68c", "lavender": "#e6e6fa", "lavender blush": "#fff0f5",
    "lawn green": "#7cfc00", "lemon chiffon": "#fffacd", "light blue": "#add8e6", "light coral": "#f08080",
    "light cyan": "#e0ffff", "light goldenrod yellow": "#fafad2", "light gray": "#d3d3d3",
    "light green": "#90ee90", "light grey": "#d3d3d3", "light pink": "#ffb6c1", "light salmon": "#ffa07a",
    "light sea green": "#20b2aa", "light sky blue": "#87cefa", "light slate gray": "#778899",
    "light slate grey": "#778899", "light steel blue": "#b0c4de", "light yellow": "#ffffe0",
    "lime": "#00ff00", "lime green": "#32cd32", "linen": "#faf0e6", "magenta": "#ff00ff",
    "maroon": "#800000", "medium aquamarine": "#66cdaa", "medium blue": "#0000cd",
    "medium orchid": "#ba55d3", "medium purple": "#9370db", "medium sea green": "#3cb371",
    "medium slate blue": "#7b68ee", "medium spring green": "#00fa9a", "medium turquoise": "#48d1cc",
    "medium violet red": "#c71585", "midnight blue": "#191970", "mint cream": "#f5fffa",
    "misty rose": "#ffe4e1", "moccasin": "#ffe4b5", "navajo white": "#ffdead", "navy": "#000080",
    "old lace": "#fdf5e6", "olive": "#808000", "olive drab": "#6b8e23", "orange": "#ffa500",
    "orange red": "#ff4500", "orchid": "#da70d6", "pale goldenrod": "#eee8aa", "pale green": "#98fb98",
    "pale turquoise": "#afeeee", "pale violet red": "#db7093", "papaya whip": "#ffefd5",
    "peach puff": "#ffdab9", "peru": "#cd853f", "pink": "#ffc0cb", "plum": "#dda0dd",
    "powder blue": "#b0e0e6", "purple": "#800080", "rebecca purple": "#663399", "red": "#ff0000",
    "rosy brown": "#bc8f8f", "royal blue": "#4169e1", "saddle brown": "#8b4513", "salmon": "#fa8072",
    "sandy brown": "#f4a460", "sea green": "#2e8b57", "seashell": "#fff5ee", "sienna": "#a0522d",
    "silver": "#c0c0c0", "sky blue": "#87ceeb", "slate blue": "#6a5acd", "slate gray": "#708090",
    "slate grey": "#708090", "snow": "#fffafa", "spring green": "#00ff7f", "steel blue": "#4682b4",
    "tan": "#d2b48c", "teal": "#008080", "thistle": "#d8bfd8", "tomato": "#ff6347",
    "turquoise": "#40e0d0", "violet": "#ee82ee", "wheat": "#f5deb3", "white": "#ffffff",
    "white smoke": "#f5f5f5", "yellow": "#ffff00", "yellow green": "#9acd32",
}

# names artists use that CSS lacks; the value is the usual one (pigment or everyday sense)
EXTRA_COLOURS: dict[str, str] = {
    "sepia": "#704214", "ochre": "#cc7722", "yellow ochre": "#e3a857", "umber": "#635147",
    "burnt umber": "#8a3324", "raw umber": "#826644", "burnt sienna": "#e97451", "raw sienna": "#d68a59",
    "vermilion": "#e34234", "ultramarine": "#120a8f", "cobalt": "#0047ab", "cobalt blue": "#0047ab",
    "prussian blue": "#003153", "cerulean": "#007ba7", "cyan blue": "#1ca9c9", "amber": "#ffbf00",
    "emerald": "#50c878", "jade": "#00a86b", "ruby": "#e0115f", "sapphire": "#0f52ba",
    "mustard": "#e1ad01", "rust": "#b7410e", "burgundy": "#800020", "wine": "#722f37", "mauve": "#e0b0ff",
    "lilac": "#c8a2c8", "peach": "#ffcba4", "cream": "#fffdd0", "charcoal": "#36454f", "taupe": "#483c32",
    "scarlet": "#ff2400", "copper": "#b87333", "bronze": "#cd7f32", "brass": "#b5a642",
    "terracotta": "#e2725b", "mint": "#98ff98", "sage": "#9caf88", "rose": "#ff007f", "blush": "#de5d83",
    "cherry": "#de3163", "lemon": "#fff44f", "lime yellow": "#e3ff00", "sky": "#87ceeb",
    "ice blue": "#99ffff", "navy blue": "#000080", "royal purple": "#7851a9", "eggplant": "#614051",
    "aubergine": "#3b0910", "cinnamon": "#d2691e", "caramel": "#c68e17", "honey": "#eba937",
    "sand": "#c2b280", "ivory white": "#fffff0", "bone": "#e3dac9", "pearl": "#eae0c8",
    "ink": "#1b1b2f", "jet": "#343434", "jet black": "#0a0a0a", "ebony": "#555d50", "slate": "#708090",
    "steel": "#7b8a94", "gunmetal": "#2a3439", "pewter": "#8e9294", "platinum": "#e5e4e2",
    "cobalt violet": "#8c4a9e", "magenta pink": "#cc338b", "neon green": "#39ff14", "neon pink": "#ff6ec7",
    "electric blue": "#7df9ff", "acid green": "#b0bf1a", "bordeaux": "#5c0120", "oxblood": "#4a0000",
    "brick": "#b22222", "brick red": "#cb4154", "blood red": "#880808", "fire red": "#ce2029",
    "sunflower": "#ffda03", "canary": "#ffef00", "canary yellow": "#ffef00", "saffron": "#f4c430",
    "tangerine": "#f28500", "pumpkin": "#ff7518", "apricot": "#fbceb1", "salmon pink": "#ff91a4",
    "baby blue": "#89cff0", "baby pink": "#f4c2c2", "bubblegum": "#ffc1cc", "periwinkle": "#ccccff",
    "cornflower": "#6495ed", "denim": "#1560bd", "petrol": "#005f6a", "aqua marine": "#7fffd4",
    "seafoam": "#93e9be", "moss": "#8a9a5b", "moss green": "#8a9a5b", "pine": "#01796f",
    "pine green": "#01796f", "bottle green": "#006a4e", "hunter green": "#355e3b", "kelly green": "#4cbb17",
    "grass green": "#3f9b0b", "pea green": "#8eab12", "avocado": "#568203", "khaki green": "#728639",
    "chestnut": "#954535", "mahogany": "#c04000", "walnut": "#773f1a", "coffee": "#6f4e37",
    "chocolate brown": "#3f2a14", "cocoa": "#875f42", "beige brown": "#a0785a", "parchment": "#f1e9d2",
    "off white": "#faf9f6", "champagne": "#f7e7ce", "rose gold": "#b76e79", "silver grey": "#c0c0c0",
    "ash": "#b2beb5", "ash grey": "#b2beb5", "smoke": "#738276", "fog": "#d7d0c8",
    # "<thing> <colour>" names
    "emerald green": "#50c878", "lemon yellow": "#fff44f", "ruby red": "#9b111e", "sapphire blue": "#0f52ba",
    "olive green": "#708238", "sea blue": "#006994", "ocean blue": "#4f42b5", "cherry red": "#de3163",
    "rose pink": "#ff66cc", "golden yellow": "#ffdf00", "jade green": "#00a86b", "mint green": "#98ff98",
    "sage green": "#9caf88", "lime green yellow": "#c5e384", "blood orange": "#d1001c", "sunset orange": "#fd5e53",
    "blue grey": "#6699cc", "blue gray": "#6699cc", "warm grey": "#9f978c", "cool grey": "#8c92ac",
    # pigments the art lexicon's palettes name (art_lexicon.toml)
    "lapis": "#26619c", "lapis lazuli": "#26619c", "viridian": "#40826d", "chrome yellow": "#ffa700",
    "cadmium yellow": "#fff600", "cadmium red": "#e30022", "naples yellow": "#fada5e",
    "madder": "#a50021", "egyptian blue": "#1034a6",
}

# basic colour words of other languages -> the English name above (for prompts written in them)
FOREIGN_COLOURS: dict[str, str] = {
    # French
    "rouge": "red", "bleu": "blue", "vert": "green", "jaune": "yellow", "noir": "black", "blanc": "white",
    "gris": "gray", "marron": "brown", "rose": "pink", "violet": "violet", "doré": "gold", "dorée": "gold",
    "argenté": "silver", "bleu marine": "navy", "turquoise": "turquoise", "pourpre": "purple",
    # German
    "rot": "red", "blau": "blue", "grün": "green", "gelb": "yellow", "schwarz": "black", "weiß": "white",
    "weiss": "white", "grau": "gray", "braun": "brown", "rosa": "pink", "lila": "purple", "golden": "gold",
    "silbern": "silver", "orangefarben": "orange",
    # Spanish / Portuguese / Italian
    "rojo": "red", "azul": "blue", "verde": "green", "amarillo": "yellow", "negro": "black",
    "blanco": "white", "dorado": "gold", "oro": "gold", "plateado": "silver", "morado": "purple",
    "marrón": "brown", "naranja": "orange", "vermelho": "red", "amarelo": "yellow", "preto": "black",
    "branco": "white", "dourado": "gold", "roxo": "purple", "rosso": "red", "blu": "blue",
    "giallo": "yellow", "nero": "black", "bianco": "white", "grigio": "gray", "viola": "violet",
    "azzurro": "sky blue", "marrone": "brown", "arancione": "orange",
    # Japanese
    "赤": "red", "青": "blue", "緑": "green", "黄色": "yellow", "黒": "black", "白": "white", "金": "gold",
    "金色": "gold", "銀": "silver", "紫": "purple", "ピンク": "pink", "オレンジ": "orange",
}


def hex_to_rgb(value: str) -> tuple[float, float, float]:
    value = value.lstrip("#")
    return tuple(int(value[i:i + 2], 16) / 255.0 for i in (0, 2, 4))


ALL_COLOURS: dict[str, str] = {**CSS_COLOURS, **EXTRA_COLOURS}
