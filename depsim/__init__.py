"""depsim: a modelling language and compiler for deployable spacecraft mechanisms."""

__version__ = "0.1.0"
