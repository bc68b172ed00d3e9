"""Light in the units the trade plans with: lumens, lux, candela per square metre, lux-hours.

units: the one conversion between a projector's ANSI lumens and the Blender light's power, and the
photometric formulas; presets: real projector models (projector_presets.toml, data only); dose: the
conservation guard (CIE 157 style categories, schedules, lux-hours, the cap on the projector image);
light_maps: the summary and colour maps of illuminance, luminance and contrast; projector_table: the
planning CSV.
"""
