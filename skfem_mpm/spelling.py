"""How a message names a setting: in Python and in a scene file.

A warning or error that advises a setting reaches Python users and scene
files' users alike (a trial's scene run was told to "use
Stabilisation(antilocking=True)"); :func:`setting` spells it for both,
from one table of the option objects' fields and their scene keys.

>>> from skfem_mpm.spelling import setting
>>> setting("antilocking", True)
'Stabilisation(antilocking=True); scene file: [solver] antilocking = true'
"""
__all__ = ["SCENE_KEYS", "PARAMETER_KEYS", "setting", "parameter",
           "did_you_mean"]

#: per option field, the option object that holds it and its scene key
#: as ``(table, key)``
SCENE_KEYS = {
    "antilocking": ("Stabilisation", ("solver", "antilocking")),
    "ghost": ("Stabilisation", ("solver", "ghost")),
    "extended_splines": ("Stabilisation", ("solver", "extended_splines")),
    "tol": ("NewtonOptions", ("solver", "tolerance")),
    "max_iter": ("NewtonOptions", ("solver", "max_iterations")),
    "line_search": ("NewtonOptions", ("solver", "line_search")),
    "newton": ("NewtonOptions", ("solver", "newton")),
    "rhs": ("NewtonOptions", ("solver", "rhs")),
    "grow_back": ("NewtonOptions", ("solver", "grow_back")),
    "kernels": ("Options", ("solver", "kernels")),
}

#: per material parameter whose scene key differs (a Python keyword), the
#: scene key
PARAMETER_KEYS = {"lambda_": "lambda"}


def _toml(value) -> str:
    """``value`` as a TOML value: ``true``, ``"fbar"``, ``0.1``."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return '"{}"'.format(value)
    return repr(value)


def setting(field: str, value) -> str:
    """The option ``field`` set to ``value``, spelled for Python and for a
    scene file (a field of :data:`SCENE_KEYS`).

    >>> setting("ghost", 0.1)
    'Stabilisation(ghost=0.1); scene file: [solver] ghost = 0.1'
    """
    owner, (table, key) = SCENE_KEYS[field]
    return "{}({}={!r}); scene file: [{}] {} = {}".format(
        owner, field, value, table, key, _toml(value))


def parameter(name: str) -> str:
    """A material parameter's name, with its scene key where that differs
    (a trial's scene, which wrote ``lambda``, was told of ``lambda_``).

    >>> parameter("lambda_"), parameter("kappa")
    ('lambda_ (scene file: lambda)', 'kappa')
    """
    key = PARAMETER_KEYS.get(name)
    return name if key is None else "{} (scene file: {})".format(name, key)


def did_you_mean(word, choices) -> str:
    """``"; did you mean 'x'?"`` with the choice nearest to a misspelt
    ``word`` (difflib's ratio 0.6 at least, a key's case and dashes
    aside), else ``""``: for messages that refuse a key or a name.

    >>> did_you_mean("friction_angel", ["cohesion", "friction_angle"])
    "; did you mean 'friction_angle'?"
    >>> did_you_mean("mohr-coulomb", ["linear_elastic", "mohr_coulomb"])
    "; did you mean 'mohr_coulomb'?"
    >>> did_you_mean("colour", ["x", "y", "element"])
    ''
    """
    import difflib
    if not isinstance(word, str):
        return ""
    choices = [c for c in choices if isinstance(c, str)]
    plain = {c.lower().replace("-", "_"): c for c in choices}
    found = difflib.get_close_matches(word.lower().replace("-", "_"),
                                      list(plain), n=1)
    return "; did you mean {!r}?".format(plain[found[0]]) if found else ""
