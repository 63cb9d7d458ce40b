"""What the device-family tests share (tests/test_device_families.py: the device row Newton;
tests/test_fused_closures.py: the fused row stepper; not a test module): the devices, the elastic
pin supports and the designs with one elastic family switched on. Each test module adds its own rows
to :data:`FAMILY_CASES` (the families test the crank torsion alone, the fused test rv80e with all of
its own families)."""
import pytest

import rvtool

DEVICES = [pytest.param(d, id=d) for d in ("cpu", "cuda:0")]

RING = {"model": "simply_supported", "ends": [-0.015, 0.015]}
OUT = {"model": "cantilever", "ends": [-0.012, 0.012]}
#: the family switched on -> (design, its edit); coarse housing meshes keep the reduction cheap
FAMILY_CASES = {
    "elastic_ring_and_output_pins": ("rd40", dict(pins={"support": RING}, output_pins={"support": OUT})),
    "cycloid_ported_housing": ("rd40", dict(housing={"model": "ports", "structure": {"mesh_size": 0.008}})),
    "crank_beam_and_torsion": ("rv40e", dict(cranks={"shaft": {"model": "simply_supported",
                                                               "torsion": "elastic"}})),
    "involute_ring_ported_housing": ("std_involute", dict(housing={"model": "ports",
                                                                  "structure": {"inner_radius": 0.056,
                                                                                "mesh_size": 0.012}})),
}


def case_design(cases, name):
    """The design of case ``name`` of ``cases`` (a shipped design, with its edit where it has one)."""
    base, edit = cases[name]
    d = rvtool.load_design(base)
    return d.replace(**edit) if edit else d


def skip_absent_device(device):
    """Skip where ``device`` is a CUDA device and none is present."""
    import warp as wp
    if device.startswith("cuda") and wp.get_cuda_device_count() == 0:
        pytest.skip(f"{device} not present")
