"""Local pressure and subsurface stress at a fixed mechanical state.

Panel solver (paper Eqs. obs_pressure_contact, obs_panel_influence) and the
plane-strain half-space stress field from surface tractions.
"""
from rvtool.pressure.panels import PanelContact, PanelResult, influence_column, panel_integral, solve_panels
from rvtool.pressure.stress import subsurface_stress

__all__ = ["PanelContact", "PanelResult", "influence_column", "panel_integral", "solve_panels", "subsurface_stress"]
