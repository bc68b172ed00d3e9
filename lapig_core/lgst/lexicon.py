"""A small bundled lexicon of art words in other languages -> English (vitrail, Buntglas, acuarela, ...).

The multilingual embedder (multilingual-e5-small) reads whole sentences in about a hundred languages,
but a lone rare word ("vitrail") can land far from its English sense, and where that embedder is not
installed the English-only MiniLM reads no other language at all. The prompt is therefore glossed
first: each known word gets its English meaning added beside it, and both go to the embedder.
Entries are the ordinary dictionary translations (French, German, Spanish, Italian, Portuguese, Dutch,
Japanese, Chinese); matching ignores case and accents.
"""
from __future__ import annotations

import re
import unicodedata

GLOSSES: dict[str, str] = {
    # stained glass
    "vitrail": "stained glass", "vitraux": "stained glass", "buntglas": "stained glass",
    "buntglasfenster": "stained glass", "glasmalerei": "stained glass", "kirchenfenster": "stained glass",
    "vidriera": "stained glass", "vitral": "stained glass", "vetrata": "stained glass", "vetrate": "stained glass",
    "glas-in-lood": "stained glass", "glas in lood": "stained glass", "ステンドグラス": "stained glass",
    "彩色玻璃": "stained glass", "花窗玻璃": "stained glass",
    # watercolour
    "aquarelle": "watercolour", "aquarell": "watercolour", "acuarela": "watercolour", "acquerello": "watercolour",
    "aquarela": "watercolour", "waterverf": "watercolour", "水彩": "watercolour", "水彩画": "watercolour",
    # drawing media
    "fusain": "charcoal", "kohle": "charcoal", "kohlezeichnung": "charcoal drawing", "carboncillo": "charcoal",
    "carbón": "charcoal", "carbone": "charcoal", "carboncino": "charcoal", "carvão": "charcoal",
    "houtskool": "charcoal", "木炭": "charcoal", "crayon": "pencil", "bleistift": "pencil", "lápiz": "pencil",
    "matita": "pencil", "lápis": "pencil", "potlood": "pencil", "鉛筆": "pencil", "croquis": "sketch",
    "esquisse": "sketch", "skizze": "sketch", "boceto": "sketch", "schizzo": "sketch", "esboço": "sketch",
    "schets": "sketch", "dessin": "drawing", "zeichnung": "drawing", "dibujo": "drawing", "disegno": "drawing",
    "desenho": "drawing", "tekening": "drawing", "encre": "ink", "tinte": "ink", "tusche": "ink", "tinta": "ink",
    "inchiostro": "ink", "inkt": "ink", "墨": "ink", "水墨画": "ink wash painting", "素描": "sketch",
    "pastell": "pastel", "pastello": "pastel", "gravure": "etching", "radierung": "etching",
    "grabado": "etching", "incisione": "etching", "gravura": "etching", "kupferstich": "engraving",
    # prints
    "gravure sur bois": "woodblock print", "estampe japonaise": "Japanese woodblock print",
    "estampe": "print", "holzschnitt": "woodcut", "farbholzschnitt": "woodblock print",
    "xilografía": "woodcut", "xilografia": "woodcut", "grabado en madera": "woodcut", "estampa japonesa":
    "Japanese woodblock print", "houtsnede": "woodcut", "木版画": "woodblock print", "浮世絵": "ukiyo-e",
    "版画": "print", "linogravure": "linocut", "linolschnitt": "linocut", "linograbado": "linocut",
    "sérigraphie": "screen print", "siebdruck": "screen print", "serigrafía": "screen print",
    "serigrafia": "screen print", "trame": "halftone", "rasterdruck": "halftone", "semitono": "halftone",
    # mosaic, tiles
    "mosaïque": "mosaic", "mosaik": "mosaic", "mosaico": "mosaic", "mozaïek": "mosaic", "モザイク": "mosaic",
    "马赛克": "mosaic", "azulejos": "tiles", "fliesen": "tiles", "carrelage": "tiles", "piastrelle": "tiles",
    # paintings
    "peinture à l'huile": "oil painting", "ölgemälde": "oil painting", "ölbild": "oil painting",
    "óleo": "oil painting", "pintura al óleo": "oil painting", "pittura a olio": "oil painting",
    "olieverf": "oil painting", "油絵": "oil painting", "油画": "oil painting", "peinture": "painting",
    "gemälde": "painting", "malerei": "painting", "pintura": "painting", "pittura": "painting", "dipinto": "painting",
    "schilderij": "painting", "絵画": "painting", "impressionniste": "impressionist",
    "impressionistisch": "impressionist", "impresionista": "impressionist", "impressionista": "impressionist",
    "pointillisme": "pointillism", "pointillismus": "pointillism", "puntillismo": "pointillism",
    "fauvisme": "fauvism", "fauvismus": "fauvism", "expressionnisme": "expressionism",
    "expressionismus": "expressionism", "expresionismo": "expressionism", "cubisme": "cubism",
    "kubismus": "cubism", "cubismo": "cubism", "bande dessinée": "comic book", "bd": "comic book",
    "comic": "comic book", "historieta": "comic book", "fumetto": "comic book", "fumetti": "comic book",
    "quadrinhos": "comic book", "漫画": "manga comic", "マンガ": "manga comic", "アニメ": "anime cartoon",
    "dessin animé": "cartoon", "zeichentrick": "cartoon", "dibujos animados": "cartoon",
    "cartone animato": "cartoon", "affiche": "poster", "plakat": "poster", "cartel": "poster",
    "manifesto": "poster", "ligne claire": "line art", "strichzeichnung": "line drawing",
    "dibujo lineal": "line drawing", "線画": "line art", "pixel art": "pixel art", "ドット絵": "pixel art",
    # light and moods
    "néon": "neon", "neón": "neon", "ネオン": "neon", "霓虹": "neon", "霓虹灯": "neon lights",
    "nuit": "night", "nocturne": "night", "nacht": "night", "nachts": "at night", "noche": "night",
    "nocturno": "night", "notte": "night", "notturno": "night", "noite": "night", "夜": "night", "夜景": "night",
    "crépuscule": "dusk", "coucher de soleil": "sunset", "dämmerung": "dusk", "abenddämmerung": "dusk",
    "sonnenuntergang": "sunset", "atardecer": "dusk", "anochecer": "dusk", "puesta de sol": "sunset",
    "crepuscolo": "dusk", "tramonto": "sunset", "pôr do sol": "sunset", "crepúsculo": "dusk",
    "schemering": "dusk", "zonsondergang": "sunset", "夕暮れ": "dusk", "夕焼け": "sunset", "黄昏": "dusk",
    "aube": "dawn", "aurore": "dawn", "morgendämmerung": "dawn", "sonnenaufgang": "sunrise", "amanecer": "dawn",
    "alba": "dawn", "aurora": "dawn", "alvorada": "dawn", "dageraad": "dawn", "夜明け": "dawn", "朝焼け": "sunrise",
    "brouillard": "fog", "brume": "mist", "nebel": "fog", "niebla": "fog", "nebbia": "fog", "névoa": "fog",
    "mist": "mist", "霧": "fog", "ensoleillé": "sunny", "sonnig": "sunny", "soleado": "sunny",
    "soleggiato": "sunny", "ensolarado": "sunny", "zonnig": "sunny", "晴れ": "sunny", "lumineux": "bright",
    "hell": "bright", "luminoso": "bright", "sombre": "dark", "dunkel": "dark", "oscuro": "dark", "scuro": "dark",
    "sombrío": "dark gloomy", "düster": "gloomy", "cupo": "gloomy", "暗い": "dark", "hiver": "winter",
    "winter": "winter", "invierno": "winter", "inverno": "winter", "冬": "winter", "rétro": "vintage",
    "ancien": "vintage", "vintage": "vintage", "antiguo": "vintage", "antico": "vintage",
    "toile": "canvas", "leinwand": "canvas", "lienzo": "canvas", "tela": "canvas", "papier": "paper",
    "papel": "paper", "carta": "paper", "紙": "paper", "lueur": "glow", "leuchten": "glow", "resplandor": "glow",
    "bagliore": "glow", "sépia": "sepia", "sepia": "sepia",
}


def _fold(text: str) -> str:
    """Lower case without accents (so 'Mosaique' finds 'mosaïque'); CJK characters are kept."""
    decomposed = unicodedata.normalize("NFD", text.lower())
    return unicodedata.normalize("NFC", "".join(c for c in decomposed if unicodedata.category(c) != "Mn"))


_FOLDED = sorted(((_fold(k), v) for k, v in GLOSSES.items()), key=lambda kv: -len(kv[0]))
_CJK = re.compile(r"[\u3040-\u30ff\u3400-\u9fff]")


def gloss(text: str) -> tuple[str, list[tuple[str, str]]]:
    """(English meanings of the lexicon words found, [(word as found, English)]), longest words first;
    a word already English ('mist', 'winter') adds nothing."""
    folded = _fold(text)
    found, taken = [], []
    for key, english in _FOLDED:
        if _CJK.search(key):
            pos = folded.find(key)
            hits = [pos] if pos >= 0 else []
        else:
            hits = [m.start() for m in re.finditer(r"(?<![\w'])" + re.escape(key) + r"(?![\w'])", folded)]
        for pos in hits:
            span = (pos, pos + len(key))
            if any(a < span[1] and span[0] < b for a, b in taken):
                continue  # inside a longer entry already found
            taken.append(span)
            if _fold(english) != key:
                found.append((text[span[0]:span[1]], english))
    return " ".join(e for _, e in found), found
