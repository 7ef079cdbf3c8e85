"""The package version, in a module of its own so that any stage can read it without importing the
package's entry points (``samplehd/__init__`` registers the Gymnasium environments)."""

__version__ = "0.1.0"
