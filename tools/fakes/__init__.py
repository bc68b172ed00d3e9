"""Fakes of rigs for the tests and benchmarks (numpy optics of K projectors and one camera); not part of the
extension the zip holds."""
