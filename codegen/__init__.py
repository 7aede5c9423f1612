"""depsim.codegen"""
