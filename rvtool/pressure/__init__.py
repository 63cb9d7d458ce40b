"""Local pressure and subsurface stress at a fixed mechanical state.

Panel solver (paper Eqs. obs_pressure_contact, obs_panel_influence), pressure observables
(Eqs. pressure_metrics, pressure_field_difference), the plane-strain half-space stress field from
normal and tangential surface tractions, local contact geometry at an accepted state and the
selection / resolution procedure.
"""
from rvtool.pressure.metrics import field_difference, panel_edges, window_mean_max
from rvtool.pressure.panels import PanelContact, PanelResult, influence_column, panel_integral, solve_panels
from rvtool.pressure.stress import sliding_hertz_stress, subsurface_stress

__all__ = ["PanelContact", "PanelResult", "field_difference", "influence_column", "panel_edges", "panel_integral",
           "sliding_hertz_stress", "solve_panels", "subsurface_stress", "window_mean_max"]
