"""A template design table as a new user writes it, and loading an edited table back (shared by the new-user
input tests)."""
import tomllib

import rvtool
from rvtool.designs.format import template


def template_table(topology):
    """The `rvtool new` template of ``topology`` (name "mine") as a TOML table."""
    return tomllib.loads(template(topology, name="mine"))


def load_table(tmp_path, table):
    """``table`` written to ``tmp_path/mine.toml`` and loaded with :func:`rvtool.load_design`."""
    import tomlkit
    p = tmp_path / "mine.toml"
    p.write_text(tomlkit.dumps(table))
    return rvtool.load_design(str(p))
