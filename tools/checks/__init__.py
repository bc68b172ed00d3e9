"""Independent readers of what Export writes (an MPCDI package, a video): the tests and benchmarks check the
writers through them; not part of the extension the zip holds."""
