"""depsim.dsl"""
