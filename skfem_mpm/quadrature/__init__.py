"""quadrature"""
