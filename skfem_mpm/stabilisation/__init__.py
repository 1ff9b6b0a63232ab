"""stabilisation"""
