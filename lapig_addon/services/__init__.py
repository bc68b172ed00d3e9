"""Jobs and decisions on plain objects, no bpy: the engine and the seams here, each stage in its folder
(docs/architecture/layout.md)."""
