"""What a user trial (98) found in the command line and its docs:
``summary.json``'s ``timings`` without a unit, VTU fields named only
inside grouped rows of the README's table, scene-file refusals that
named neither the file nor the table's index, and a follow-on error
after a refused support value."""
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_timings_have_a_unit():
    """``units`` had ``wall_seconds`` but not ``timings`` (seconds per
    phase)."""
    from skfem_mpm.cli import summary_units
    for dim, system in ((2, "SI"), (3, "kN-m")):
        units = summary_units(dim, system=system)
        assert units["timings"] == units["wall_seconds"] == "s"


def test_the_vtu_table_has_a_row_per_field_a_reader_looks_for():
    """``strain``, ``volume0`` and ``yielding`` were named only inside
    rows of two or three fields: each has a row of its own."""
    rows = [line.split("|") for line in README.read_text().splitlines()
            if line.startswith("| ")]
    fields = [row[2].strip() for row in rows if len(row) > 4]
    for name in ("stress", "strain", "volume", "volume0", "yielding"):
        assert "`{}`".format(name) in fields, name
