"""depsim.runtime"""
