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


def test_counts_and_errors_have_a_unit():
    """A lecturer's trial: ``units`` had no entry for ``error`` (a
    dimensionless error) and ``points`` (a count)."""
    from skfem_mpm.cli import summary_units
    for dim, system in ((1, "SI"), (2, "kN-m")):
        units = summary_units(dim, system=system)
        for key in ("error", "points", "steps", "steps_run"):
            assert units[key] == "-", key


def test_point_cloud_names_its_fields_and_h5py():
    """A lecturer's trial: ``point_cloud``'s docstring was one line,
    naming no field, and its ``.xdmf`` needs ``h5py``, which no extra
    installs."""
    from skfem import MeshQuad
    from skfem_mpm import seed_points
    from skfem_mpm.scenes.output import point_cloud
    cloud = point_cloud(seed_points(MeshQuad(), 2))
    doc = point_cloud.__doc__
    for name in cloud.point_data:
        assert "``{}``".format(name) in doc, name
    assert "h5py" in doc


def test_the_vtu_table_has_a_row_per_field_a_reader_looks_for():
    """``strain``, ``volume0`` and ``yielding`` were named only inside
    rows of two or three fields: each has a row of its own."""
    rows = [line.split("|") for line in README.read_text().splitlines()
            if line.startswith("| ")]
    fields = [row[2].strip() for row in rows if len(row) > 4]
    for name in ("stress", "strain", "volume", "volume0", "yielding"):
        assert "`{}`".format(name) in fields, name


WALL = """\
name = "retaining wall"
units = "kN-m"
[grid]
x = [0.0, 6.0, 24]
y = [0.0, 4.0, 16]
[[bodies]]
name = "backfill"
region = {{ x = [0.0, 4.0], y = [0.0, 3.0] }}
material = {{ model = "linear_elastic", E = 2e4, nu = 0.3 }}
[[obstacles]]
name = "wall"
box = {{ x = [{wall}, 4.5], y = [0.0, 4.0] }}
displacement = [0.02, 0.0]
[[supports]]
name = "base"
boundary = "bottom"
{extra}
"""
H = 6. / 24      # the grid's cell size along x (and y: 4 / 16)


def refusal(tmp_path, capsys, text):
    """``skfem-mpm run`` of ``text``: its exit code and stderr, the
    output folder (not made where refused before any work)."""
    from skfem_mpm.cli import main
    path = tmp_path / "scene.toml"
    path.write_text(text)
    out = tmp_path / "out"
    code = main(["run", str(path), "--out", str(out), "--no-progress"])
    return code, capsys.readouterr().err, out


def test_an_obstacle_off_the_grid_is_named_by_file_and_table(tmp_path,
                                                             capsys):
    """``obstacle 'wall' ... never reaches the grid`` named neither the
    file nor the table."""
    code, err, out = refusal(tmp_path, capsys, WALL.format(
        wall=7.0, extra="").replace("4.5]", "8.0]"))
    assert code == 2 and not out.exists()
    assert "scene.toml: obstacles[0]: obstacle 'wall' (bounds [[7.0, " \
        "8.0], [0.0, 4.0]], moving by [0.02, 0.0]) never reaches the grid " \
        "(bounds [[0.0, 6.0], [0.0, 4.0]])" in err
    assert "(lengths in m)" in err


def test_a_support_off_the_grid_lines_names_the_nearest(tmp_path, capsys):
    """A support's region between grid lines was refused at set-up with
    no line named (the ``at`` form named the nearest node): both are
    refused before any work, naming the table and the nearest lines."""
    x = 2.1
    below, above = H * (x // H), H * (x // H + 1)
    code, err, out = refusal(tmp_path, capsys, WALL.format(
        wall=4.0, extra='[[supports]]\nname = "anchor"\nregion = {{ x = '
        '[{0}, {0}], y = [0.0, 3.0] }}\ncomponents = ["x"]'.format(x)))
    assert code == 2 and not out.exists()
    assert "scene.toml: supports[1].region: support 'anchor' holds no " \
        "grid node (x = {!r} lies between the grid lines x = {!r} and " \
        "x = {!r})".format(x, below, above) in err
    at = [2.1, 1.3]
    nearest = [H * round(v / H) for v in at]
    code, err, out = refusal(tmp_path, capsys, WALL.format(
        wall=4.0, extra='[[supports]]\nname = "pin"\nat = {}'.format(at)))
    assert code == 2 and not out.exists()
    assert "scene.toml: supports[1].at: support 'pin' has no grid node " \
        "there (nearest is {})".format(nearest) in err


def test_an_obstacle_over_a_body_is_refused_before_work(tmp_path, capsys):
    """A wall box overlapping the backfill was refused after the set-up
    (its warnings printed), "0.5 inside" with no unit: refused before any
    work, with the overlap in the scene's length unit; one within the
    obstacle's tolerance (1e-3 cells) runs as before."""
    wall = 3.5
    code, err, out = refusal(tmp_path, capsys, WALL.format(wall=wall,
                                                           extra=""))
    assert code == 2 and not out.exists()
    assert err.count("\n") == 1          # no warning of a set-up before
    assert "scene.toml: obstacles[0].box: obstacle 'wall' overlaps body " \
        "'backfill' at the start, {:.3g} m across (where x in [{!r}, 4.0]" \
        ", y in [0.0, 3.0])".format(4. - wall, wall) in err
    from skfem_mpm.scenes.scene_file import load_scene
    path = tmp_path / "touching.toml"
    path.write_text(WALL.format(wall=4. - .5e-3 * H, extra=""))
    assert load_scene(path).obstacles[0].name == "wall"


def test_a_tied_obstacle_inside_a_body_is_taken(tmp_path):
    """The run refuses no tied obstacle for lying inside a body (an
    anchor holds material inside it); the scene file refused one as
    overlapping the body ("it would hold material inside it")."""
    from skfem_mpm.scenes.scene_file import load_scene
    path = tmp_path / "anchor.toml"
    path.write_text(WALL.format(wall=3.5, extra="").replace(
        "displacement = [0.02, 0.0]", 'friction = "tied"'))
    obstacle = load_scene(path).obstacles[0]
    assert (obstacle.name, obstacle.friction) == ("wall", "tied")


def test_a_refused_support_value_is_said_once(tmp_path, capsys):
    """``value = [0, 0, -0.05]`` with ``components = ["z"]`` was refused,
    and then its ``bodies = ["pile"]`` too, as though not a list of body
    names."""
    code, err, out = refusal(tmp_path, capsys, WALL.format(
        wall=4.0, extra='[[supports]]\nregion = { y = [3.0, 3.0] }\n'
        'components = ["y"]\nvalue = [0, 0, -0.05]\nbodies = ["backfill"]'))
    assert code == 2
    assert "supports[1].value: must be a list of 1 finite numbers" in err
    assert "bodies" not in err
    # without a value, the bodies are refused for that reason
    code, err, out = refusal(tmp_path, capsys, WALL.format(
        wall=4.0, extra='[[supports]]\nregion = { y = [3.0, 3.0] }\n'
        'components = ["y"]\nbodies = ["backfill"]'))
    assert code == 2 and "supports[1].bodies: needs a value" in err


def test_the_scene_file_reference_says_how_to_write_tresca():
    """No ``tresca`` model, and the scene-file reference did not say how
    to write one: its two forms load, and a plane-strain pure shear
    past yield flows at the shear strength c_u in both."""
    import re
    import numpy as np
    from skfem_mpm.mechanics.materials import initial_state
    from skfem_mpm.scenes.scene_file import parse_scene, tomllib
    text = (README.parent / "docs" / "scene_files.rst").read_text()
    section = text.split("Undrained soil (Tresca)\n")[1].split("\n----")[0]
    c_u = float(re.search(r"# c_u = ([0-9.]+)", section).group(1))
    block = section.split(".. code-block:: toml\n")[1].split("\n\n")[0]
    forms = [line.split("# or")[0] for line in block.split(
        "material = ")[1:]]
    assert len(forms) == 2
    shear = []
    for form in forms:
        material = tomllib.loads("m = " + " ".join(form.split()))["m"]
        scene = parse_scene({
            "grid": {"x": [0., 1., 1], "y": [0., 1., 1]},
            "bodies": [{"region": {}, "material": material}],
            "supports": [{"boundary": "y-"}]})
        model = scene.bodies[0].material
        eps = np.array([[1e-2], [-1e-2], [0.]])     # plane-strain shear
        tau = model.principal_update(eps, initial_state(model, 1))[0]
        shear.append(float(tau.max() - tau.min()) / 2)
    assert np.allclose(shear, c_u, rtol=1e-4)


QUARTER = """\
name = "quarter pile"
[grid]
x = [0.0, 1.0, 4]
y = [0.0, 1.0, 4]
z = [0.0, 2.5, 10]
[[bodies]]
name = "soil"
region = { x = [0.0, 1.0], y = [0.0, 1.0], z = [0.0, 2.0] }
material = { model = "linear_elastic", E = 2e4, nu = 0.3 }
[[bodies]]
name = "pile"
region = { x = [0.0, 0.25], y = [0.0, 0.25], z = [1.0, 2.5] }
replaces = ["soil"]
material = { model = "linear_elastic", E = 3e7, nu = 0.2 }
[[supports]]
name = "base"
boundary = "z-"
[[supports]]
name = "xsides"
boundary = ["x-", "x+"]
components = ["x"]
[[supports]]
name = "ysides"
boundary = ["y-", "y+"]
components = ["y"]
[[supports]]
name = "pilehead"
region = { x = [0.0, 0.25], y = [0.0, 0.25], z = [2.5, 2.5] }
value = [-0.05]
bodies = ["pile"]
components = ["z"]
"""


def test_a_quarter_model_is_sliced_on_its_symmetry_plane(tmp_path,
                                                         monkeypatch):
    """A quarter model's pile (pushed by a moving support at its head) and
    footing (a rigid body) lie on the symmetry planes x = 0 and y = 0:
    the deformed shape's slice is the layer of points on one (it was
    y = 0.439 m, through none of the pile), the roller holding that
    plane is named, not marked at every node, and the figure has no
    empty margins (the pile's had a third of its height empty)."""
    import numpy as np
    from skfem_mpm import cli
    from skfem_mpm.scenes import plot
    from skfem_mpm.scenes.scene import build_points
    from skfem_mpm.scenes.scene_file import load_scene
    kept = {}
    save = plot.save_figure

    def keep(fig, path, *args, **kwargs):
        kept["title"] = fig.axes[0].get_title()
        kept["legend"] = [t.get_text() for ax in fig.axes if ax.get_legend()
                          for t in ax.get_legend().get_texts()]
        save(fig, path, *args, **kwargs)
    monkeypatch.setattr(plot, "save_figure", keep)
    for name, text in (("pile", QUARTER), ("footing", QUARTER.replace(
            'replaces = ["soil"]', 'replaces = ["soil"]\nrigid = { '
            'displacement = [0.0, 0.0, -0.05] }').split("[[supports]]\n"
            'name = "pilehead"')[0])):
        path = tmp_path / (name + ".toml")
        path.write_text(text)
        scene = load_scene(path)
        pts = build_points(scene, scene.grid.build()[0])
        layer = .5 * 1. / 4 / 2       # half the points' spacing in y
        png = tmp_path / (name + ".png")
        cli.plot_deformed_shape(scene, pts, "at the start", None, png, 0.)
        assert "slice y = {:.3g} m".format(layer) in " ".join(
            kept["title"].split()), name
        assert "ysides (y- + y+): y fixed (holds the plane of this " \
            "slice, not marked)" in kept["legend"]
        image = pyplot_image(png)
        rows = np.flatnonzero((image < .9).any(axis=1))
        columns = np.flatnonzero((image < .9).any(axis=0))
        assert rows[0] < 20 and rows[-1] > image.shape[0] - 20, name
        assert columns[0] < 20 and columns[-1] > image.shape[1] - 20, name


def pyplot_image(path):
    """The PNG at ``path`` as grey levels (rows, columns), 0 to 1."""
    from skfem_mpm.scenes.plot import pyplot
    image = pyplot().imread(str(path))
    return image[..., :3].mean(axis=2)
