"""Configuration files: YAML read once into frozen, validated objects.

A configuration file is a YAML mapping whose top-level sections are the fields of :class:`Config`.
Every option has a default in code; unknown keys are errors that name the key and the allowed ones.
Command-line overrides ``--set KEY=VALUE`` use dotted paths into the file (``blade.mode=toolpath``); a bare
name that is not a section key is a blade parameter (``alpha=25`` is ``blade.parameters.alpha=25``). Values
are parsed as YAML scalars, so ``0.005`` is a number and ``G1`` a string.

Sections: ``blade:`` (:class:`BladeConfig`), ``mesh:`` (``MeshConfig``), ``flow:`` (:class:`FlowConfig`),
``solver:`` (:class:`SolverConfig`). The mesh's ``flow_speed`` and ``viscosity`` (first-cell height) follow
``flow:`` unless the ``mesh:`` section sets them: use :meth:`Config.mesh_spec`.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import reprlib
import warnings
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar, Literal, Self, get_args, get_origin, get_type_hints

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    ValidatorFunctionWrapHandler,
    create_model,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from geometry import BladeSpec, Continuity, Mode, ParameterError, ParameterSpace
from geometry.examples import TABLE4_C2_DESIGN
from meshing import LEVELS, MeshSpec, MeshSpecError
from meshing.spec import BOUNDS as MESH_BOUNDS
from meshing.spec import FIELD_DOCS as MESH_FIELD_DOCS
from optimizer import yamlsource
from optimizer.yamlsource import Source
from solver.assembly import CONVECTION_SCHEMES
from solver.gradient import LIMITERS
from solver.pressure import FACE_VELOCITIES
from solver.settings import SimpleSettings, setting_doc
from solver.simple import ALGORITHMS, PRESSURE_GRADIENTS
from solver.turbulence import (
    MODELS,
    OMEGA_PRODUCTIONS,
    OMEGA_WALL_FLUXES,
    SST,
    VELOCITY_GRADIENTS,
    WALL_TREATMENTS,
)
from solver.warmstart import INITIAL_FIELDS


class ConfigError(ValueError):
    """A configuration file or override that cannot be used; the message names the offending key."""


class ConfigWarning(UserWarning):
    """A configuration that runs but lies outside what the solver was validated for (the command line
    prints it as ``millfoil: warning: ...``)."""


def _short_repr() -> reprlib.Repr:
    short = reprlib.Repr()   # Python 3.11 has no keyword arguments for these
    short.maxlevel, short.maxlist, short.maxtuple, short.maxdict, short.maxset = 2, 4, 4, 4, 4
    short.maxstring, short.maxother, short.maxlong = 60, 60, 40
    return short


_REPR = _short_repr()


def shorten(value: Any) -> str:
    """``repr(value)`` cut to about 80 characters (nesting, items and digits elided with ``...``): what every
    error message shows of a user's input, so that no input can make a message large."""
    return _REPR.repr(value)


class Section(BaseModel):
    """Base of every configuration section (``blade:``, ``mesh:``, ``flow:``, ``solver:`` and the campaign's):
    frozen; an unknown key is an error naming the allowed ones; numbers are finite (no nan, no inf); a
    boolean is never read as a number (``alpha: true`` would otherwise be 1). The same refusals whether a
    section is read from a file (:func:`explain` adds the file and line) or built in Python."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @model_validator(mode="wrap")
    @classmethod
    def _unknown_keys_name_the_allowed(cls, data: Any, handler: ValidatorFunctionWrapHandler) -> Any:
        """pydantic's ``extra_forbidden`` errors of this section's own keys as ``unknown_key`` errors whose
        message names the allowed keys (every other error kept, so that all are reported at once)."""
        try:
            return handler(data)
        except ValidationError as exc:
            errors = exc.errors()
            if not any(e["type"] == "extra_forbidden" and len(e["loc"]) == 1 for e in errors):
                raise
            raise ValidationError.from_exception_data(cls.__name__, [_unknown_key(cls, e) for e in errors]) from None

    @field_validator("*", mode="before")
    @classmethod
    def _no_boolean_for_a_number(cls, v: Any, info: ValidationInfo) -> Any:
        field = cls.model_fields.get(info.field_name) if info.field_name else None
        if field is not None and _wants_number(field.annotation):
            where = _boolean_in(v, ())
            if where is not None:
                raise _BooleanForNumber(where)
        return v


def _unknown_key(section: type[BaseModel], error: Mapping[str, Any]) -> Any:
    """``error`` (of :meth:`ValidationError.errors`) ready to be raised again: an unknown key of ``section``
    itself as an ``unknown_key`` error naming the allowed keys, one of a nested section rebuilt as such."""
    if error["type"] == "extra_forbidden" and len(error["loc"]) == 1:
        key = error["loc"][0]
        name = _short_key(key) if isinstance(key, str) else shorten(key)
        ctx = {"text": f"unknown key '{name}'; allowed: {', '.join(section.model_fields)}",
               "allowed": ", ".join(section.model_fields)}
    elif error["type"] == "unknown_key":
        ctx = error["ctx"]
    else:
        return error
    return {"type": PydanticCustomError("unknown_key", "{text}", ctx), "loc": error["loc"], "input": error["input"]}


def _wants_number(annotation: Any) -> bool:
    """Whether ``annotation`` holds numbers and no booleans (``float``, ``int | None``, ``dict[str, float]``,
    ``tuple[float, float]``...)."""
    args = get_args(annotation)
    if annotation is bool or bool in args:
        return False
    if annotation in (int, float):
        return True
    return get_origin(annotation) is not Literal and any(_wants_number(a) for a in args)


def _boolean_in(value: Any, where: tuple) -> tuple | None:
    """The path of a boolean in ``value`` (``()`` for ``value`` itself, ``("alpha",)``, ``(1,)``), else None."""
    if isinstance(value, bool):
        return where
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list | tuple) else ()
    for key, item in items:
        found = _boolean_in(item, (*where, key))
        if found is not None:
            return found
    return None


class _BooleanForNumber(ValueError):
    """A boolean where a number is expected; ``path``: where below the field (for the error's location)."""

    def __init__(self, path: tuple):
        super().__init__("a number is expected, not a boolean (true/false, yes/no and on/off are booleans in "
                         "YAML)")
        self.path = path


class BladeConfig(Section):
    """``blade:`` section — the blade family and one blade of it.

    ``parameters`` are the values of one blade (metres and degrees; parameters with a default — L, d_s4,
    d_p4, R — may be left out). A section that names neither ``mode`` nor ``continuity`` is the C2 design
    blade of Table 4 of the paper: its parameters default to Table 4's, the given ones replacing them; a
    section that names its own family gives all its parameters (Table 4's would belong to another family).
    ``bounds`` (``name: [lower, upper]``) and ``fixed`` (``name: value``) change the optimisation space of
    Table 6: a bound frees a fixed parameter or narrows a range, a fixed value removes a design variable.
    """

    mode: Mode = Field(Mode(TABLE4_C2_DESIGN["mode"]), description="blade family: how the profile is built "
                       "(geometry.Mode: the paper's parametrisations)")
    continuity: Continuity = Field(Continuity(TABLE4_C2_DESIGN["continuity"]), description="continuity of the "
                                   "profile's curves where they join (geometry.Continuity)")
    parameters: dict[str, float] = Field(default_factory=dict, description="values of one blade, name: value (m "
                                         "and degrees; `millfoil space` lists the names); left out: Table 4's C2 "
                                         "design unless the section names its own family")
    bounds: dict[str, tuple[float, float]] = Field(default_factory=dict, description="name: [lower, upper], m or "
                                                   "degrees: frees a fixed parameter or narrows a range of Table 6")
    fixed: dict[str, float] = Field(default_factory=dict, description="name: value, m or degrees: removes a "
                                    "design variable from the optimisation space")

    @model_validator(mode="before")
    @classmethod
    def _table4_unless_own_family(cls, data: Any) -> Any:
        if isinstance(data, dict) and "mode" not in data and "continuity" not in data:
            given = data.get("parameters") or {}
            if isinstance(given, dict):
                data = {**data, "parameters": {**TABLE4_C2_DESIGN["parameters"], **given}}
        return data

    @field_validator("mode", mode="before")
    @classmethod
    def _lower(cls, v: Any) -> Any:
        return v.lower() if isinstance(v, str) else v

    @field_validator("continuity", mode="before")
    @classmethod
    def _upper(cls, v: Any) -> Any:
        return v.upper() if isinstance(v, str) else v

    def blade_spec(self) -> BladeSpec:
        """The validated blade: family and parameter values (raises ConfigError naming a bad parameter)."""
        try:
            return BladeSpec.from_values(self.mode, self.continuity, self.parameters)
        except ParameterError as exc:
            raise ConfigError(f"blade.parameters: {exc}") from None

    def space(self) -> ParameterSpace:
        """The optimisation space (raises ConfigError naming a bad bound or fixed value)."""
        try:
            return ParameterSpace.default(self.mode, self.continuity, self.bounds, self.fixed)
        except ParameterError as exc:
            raise ConfigError(f"blade.bounds/fixed: {exc}") from None


class _MeshBase(Section):
    def given(self) -> dict[str, Any]:
        """The MeshSpec fields this section sets (``level`` apart): those not None."""
        return {k: v for k, v in self.model_dump().items() if k != "level" and v is not None}


def _mesh_doc(name: str) -> str:
    """The description of a ``mesh:`` key: the MeshSpec field's, and what leaving it out (null) means."""
    doc = MESH_FIELD_DOCS[name]
    if name in LEVELS["medium"]:
        return f"{doc}; null: the level's value"
    if name in ("flow_speed", "viscosity"):
        return doc
    return f"{doc}; null: {getattr(MeshSpec(), name):g}"


def _mesh_extra(name: str) -> dict[str, str]:
    """The unit, range and why of a MeshSpec field (:data:`meshing.spec.BOUNDS`), for the schema."""
    bound = MESH_BOUNDS.get(name)
    return {} if bound is None else {k: v for k, v in (("unit", bound.unit), ("range", bound.text()),
                                                       ("why", bound.why)) if v}


# ``mesh:`` section — the resolution ``level`` and any field of :class:`meshing.MeshSpec` (domain size in
# chords, offsets, y+, flow speed, viscosity, growth...); a key left out keeps the level's value. Built from
# MeshSpec's fields so that the two cannot drift apart.
MeshConfig = create_model(
    "MeshConfig",
    __base__=_MeshBase,
    __doc__="``mesh:`` section: resolution level and MeshSpec overrides (see meshing.MeshSpec).",
    level=(Literal[tuple(LEVELS)], Field("medium", description=MESH_FIELD_DOCS["level"])),
    **{f.name: ({"float": float, "int": int}[f.type] | None, Field(None, description=_mesh_doc(f.name),
                                                                    json_schema_extra=_mesh_extra(f.name)))
       for f in dataclasses.fields(MeshSpec) if f.name != "level"},
)


class FlowConfig(Section):
    """``flow:`` section: the flow around the blade (Vessaz et al. 2013, §3.2); water at 20 °C by default.
    Forces per unit span (N/m) times ``span`` give the forces on the blade section (N)."""

    speed: float = Field(10.0, ge=1e-3, le=100.0, description="C0, the uniform inlet velocity along +x, m/s",
                         json_schema_extra={"unit": "m/s", "why": "hydraulic machines' relative velocities stay "
                                            "below ~60 m/s (cavitation); below 1 mm/s a blade's flow is creeping flow"})
    density: float = Field(998.2, ge=0.1, le=2.0e4, description="rho, the fluid's density, kg/m³",
                           json_schema_extra={"unit": "kg/m³", "why": "from a gas at low pressure to mercury "
                                              "(13 546 kg/m³)"})
    viscosity: float = Field(1.002e-3, ge=1e-6, le=1.0e3, description="mu, the fluid's dynamic viscosity, Pa s",
                             json_schema_extra={"unit": "Pa s", "why": "a dynamic viscosity, from gases (~1e-5 Pa s) "
                                                "to heavy oils (~1e3 Pa s)"})
    intensity: float = Field(0.05, ge=0, le=1, description="inlet turbulence intensity I (turbulence models "
                             "only), a fraction: 0.05 is 5 %", json_schema_extra={"why": "a fraction: 0.05 is 5 %"})
    viscosity_ratio: float = Field(10.0, gt=0, le=1.0e4, description="inlet eddy-to-molecular viscosity ratio "
                                   "nu_t / nu (turbulence models only)",
                                   json_schema_extra={"why": "nu_t / nu at the inlet: 1-100 in practice; above 1e4 "
                                                      "the inflow's eddy viscosity swamps the blade's boundary layer"})
    span: float | None = Field(None, gt=0, le=1.0e3, description="span depth of Eq. 23 C_L = F_Y / (rho C0²/2 L "
                               "span), m; null: 0.04 L (the paper's 0.04 L², 4 mm for L = 0.1 m)",
                               json_schema_extra={"unit": "m", "why": "a multiplier of the forces per unit span"})

    @property
    def kinematic_viscosity(self) -> float:
        """nu = mu / rho, m²/s."""
        return self.viscosity / self.density

    def span_for(self, chord: float) -> float:
        """The span depth (m) for a blade of chord ``chord`` (m)."""
        return self.span if self.span is not None else 0.04 * chord

    def reynolds(self, chord: float) -> float:
        """Chord Reynolds number ``speed * chord / kinematic_viscosity`` (chord in m)."""
        return self.speed * chord / self.kinematic_viscosity


#: Chord Reynolds numbers each flow model of :data:`solver.turbulence.MODELS` was validated for
#: (docs/explanation/validation.md): outside them a configuration runs with a :class:`ConfigWarning`.
#: ``sst``: the channel at 1e5, the blades at 1e6, the flat plate at 5e6 / m and NACA 0012 at 6e6.
#: ``laminar``: the cylinder at 20, the cavity at 100 and 1 000, NACA 0012 at 1 000 and 2 000; a blade's
#: boundary layer is turbulent long before 1e5 anyway.
VALIDATED_REYNOLDS = {"sst": (1.0e5, 1.0e7), "laminar": (1.0, 2.0e3)}


#: Fields of :class:`solver.SimpleSettings` that are not keys of the ``solver:`` section, and why.
SETTINGS_NOT_CONFIGURED = {
    "monitor_groups": "the pipeline monitors the blade (its forces, with C_max)",
    "stop_monitors": "the pipeline's stop test waits for the objectives' monitors (F_Y and C_max)",
    "momentum_solver": "linear-solver settings objects, tuned per equation in the solver",
    "pressure_solver": "linear-solver settings objects, tuned per equation in the solver",
    "blas_threads": "how a machine runs the solve, not what it computes (the results are the same); the "
                    "solver's default (1) is the fastest measured",
}
#: The registry that owns the choices of each text field of :class:`solver.SimpleSettings` (its keys are the
#: choices; the solver looks the value up there).
SETTING_CHOICES: dict[str, Mapping[str, Any]] = {
    "algorithm": ALGORITHMS, "convection": CONVECTION_SCHEMES, "limiter": LIMITERS,
    "pressure_gradient": PRESSURE_GRADIENTS, "face_velocity": FACE_VELOCITIES,
}
#: Keys of the ``solver:`` section that are fields of :class:`solver.turbulence.SST`: ``{key: (SST field, the
#: registry of its choices)}``; used when ``model`` is ``sst``.
SST_KEYS: dict[str, tuple[str, Mapping[str, Any]]] = {
    "wall_treatment": ("wall_treatment", WALL_TREATMENTS),
    "omega_production": ("omega_production", OMEGA_PRODUCTIONS),
    "omega_wall_flux": ("omega_wall_flux", OMEGA_WALL_FLUXES),
    "sst_velocity_gradient": ("velocity_gradient", VELOCITY_GRADIENTS),
}
_RULE_KEYS = ("ge", "gt", "le", "lt", "why", "unit")
_SCALARS = (bool, int, float, str)


def _setting_rules() -> dict[str, dict[str, Any]]:
    """Bounds (``ge``/``gt``/``le``, ``why``, ``unit``: from each field's metadata) and ``choices`` (from
    :data:`SETTING_CHOICES`) of the configured :class:`solver.SimpleSettings` fields."""
    rules = {}
    for f in dataclasses.fields(SimpleSettings):
        rule = {k: f.metadata[k] for k in _RULE_KEYS if k in f.metadata}
        if f.name in SETTING_CHOICES:
            rule["choices"] = tuple(SETTING_CHOICES[f.name])
        if rule and f.name not in SETTINGS_NOT_CONFIGURED:
            rules[f.name] = rule
    return rules


#: Bounds and choices of the configured settings, read from :class:`solver.SimpleSettings` and the solver's
#: registries (one definition: the two cannot drift apart). The solver checks the choices again; here they
#: make a bad value a configuration error that names the key. ``why``: the reason a bound is shown with.
SETTING_RULES: dict[str, dict[str, Any]] = _setting_rules()


def _choice(registry: Mapping[str, Any]) -> Any:
    return Literal[tuple(registry)]


def _setting_fields() -> dict[str, tuple[Any, Any]]:
    """The ``solver:`` keys made from :class:`solver.SimpleSettings`: ``{name: (annotation, Field)}`` for
    every field with a scalar (or optional scalar) type, bar :data:`SETTINGS_NOT_CONFIGURED`; the default is
    :meth:`solver.SimpleSettings.for_blades`', the description the field's own."""
    hints = get_type_hints(SimpleSettings)
    blades = SimpleSettings.for_blades()
    out = {}
    for f in dataclasses.fields(SimpleSettings):
        hint = hints[f.name]
        optional = type(None) in get_args(hint)
        base = next(a for a in get_args(hint) if a is not type(None)) if optional else hint
        if f.name in SETTINGS_NOT_CONFIGURED or base not in _SCALARS:
            continue
        rules = dict(SETTING_RULES.get(f.name, {}))
        choices = rules.pop("choices", None)
        why, unit = rules.pop("why", None), rules.pop("unit", None)
        annotation = Literal[choices] if choices else base
        extra = {k: v for k, v in (("unit", unit), ("why", why)) if v}
        out[f.name] = (annotation | None if optional else annotation,
                       Field(getattr(blades, f.name), description=f.metadata["doc"], json_schema_extra=extra or None,
                             **rules))
    return out


def _sst_fields() -> dict[str, tuple[Any, Any]]:
    """The ``solver:`` keys of :data:`SST_KEYS`: choices from the SST's registries, default
    :meth:`solver.turbulence.SST.for_blades`', the description the SST field's own."""
    blades = SST.for_blades()
    return {key: (_choice(registry), Field(getattr(blades, name), description=setting_doc(SST, name)))
            for key, (name, registry) in SST_KEYS.items()}


class _SolverBase(Section):
    """``solver:`` section: the flow model, its initial field and the steady solver's settings (the mesh
    level is in ``mesh:``). Generated from :class:`solver.SimpleSettings` and :class:`solver.turbulence.SST`:
    their fields' descriptions, their blade defaults (``for_blades()``) and the solver's registries of
    choices; ``model`` and ``initial`` are the section's own keys (their choices from
    :data:`solver.turbulence.MODELS` and :data:`solver.warmstart.INITIAL_FIELDS`)."""

    model: _choice(MODELS) = Field("sst", description="flow model, solver.turbulence.MODELS: sst (Menter k-omega "
                                   "SST-2003, the paper's model) or laminar")

    @field_validator("*", mode="before")
    @classmethod
    def _lower(cls, v: Any) -> Any:
        return v.lower() if isinstance(v, str) else v    # every text key of the section is a choice

    def settings(self) -> dict[str, Any]:
        """The keys that are :class:`solver.SimpleSettings` fields, as its keyword arguments."""
        return {name: getattr(self, name) for name in SETTING_KEYS}

    def sst_settings(self) -> dict[str, Any]:
        """The keys that are :class:`solver.turbulence.SST` fields, as its keyword arguments
        (``SST.for_blades(**config.solver.sst_settings())`` is the section's model when ``model`` is sst)."""
        return {name: getattr(self, key) for key, (name, _) in SST_KEYS.items()}


_SETTING_FIELDS = _setting_fields()
#: The keys of the ``solver:`` section that are :class:`solver.SimpleSettings` fields.
SETTING_KEYS = tuple(_SETTING_FIELDS)
SolverConfig = create_model(
    "SolverConfig",
    __base__=_SolverBase,
    __doc__=_SolverBase.__doc__,
    **_sst_fields(),
    initial=(_choice(INITIAL_FIELDS), Field(
        "freestream", description="initial field, solver.warmstart.INITIAL_FIELDS: freestream (uniform (C0, 0)), "
        "rest (zero velocity) or potential (the potential flow around the blade) "
        "(docs/decisions/0016-initial-field.md)")),
    **_SETTING_FIELDS,
)


class Config(Section):
    """A whole configuration file."""

    #: The names a bare ``--set NAME=VALUE`` (no dot, not a section) may give as a blade parameter
    #: (``alpha=25`` is ``blade.parameters.alpha=25``); None: any name (the blade's own check then names an
    #: unknown parameter). A schema that lists them refuses any other bare name as an unknown key.
    bare_parameter_names: ClassVar[frozenset[str] | None] = None

    blade: BladeConfig = Field(BladeConfig(), description="the blade family and one blade of it, or the "
                               "optimisation space")
    mesh: MeshConfig = Field(MeshConfig(), description="the mesh: resolution level and meshing.MeshSpec overrides")
    flow: FlowConfig = Field(FlowConfig(), description="the flow around the blade: inlet speed, fluid, inlet "
                             "turbulence, span")
    solver: SolverConfig = Field(SolverConfig(), description="the flow model, its initial field and the steady "
                                 "solver's settings")

    def mesh_spec(self) -> MeshSpec:
        """The mesh specification: the ``mesh:`` level's preset with the keys the section sets, and
        ``flow_speed`` and ``viscosity`` (kinematic, m²/s) from ``flow:`` unless the section sets them;
        checked (:meth:`meshing.MeshSpec.check_for`: Reynolds number, first cell, cell budget) for the
        chords the blade space allows (both ends of a free ``L``)."""
        from_flow = {"flow_speed": self.flow.speed, "viscosity": self.flow.kinematic_viscosity}
        try:
            spec = MeshSpec.for_level(self.mesh.level, **{**from_flow, **self.mesh.given()})
        except ValueError as exc:
            raise ConfigError(_mesh_message(exc)) from None
        for chord in self.space_chords():
            self.check_mesh_for(chord, spec)
        return spec

    def check_mesh_for(self, chord: float, spec: MeshSpec | None = None) -> None:
        """ConfigError unless the mesh can be built within its limits around a blade of ``chord`` (m)."""
        spec = spec or self.mesh_spec()
        try:
            spec.check_for(chord)
        except MeshSpecError as exc:
            # The Reynolds number, and so the first cell, follow flow: unless mesh: sets its own; say so,
            # since a flow: value is then as much the cause as the mesh key the message names.
            follows = [f"flow.{k}" for k, mesh_key in (("speed", "flow_speed"), ("density", "viscosity"),
                                                       ("viscosity", "viscosity"))
                       if getattr(self.mesh, mesh_key, None) is None]
            why = (f" (the Reynolds number follows {', '.join(follows)})"
                   if follows and exc.field in ("flow_speed", "y_plus") else "")
            raise ConfigError(_mesh_message(exc) + why) from None

    def space_chords(self) -> tuple[float, ...]:
        """The chords (m) of the blade space: its fixed ``L``, or both ends of ``L``'s range."""
        space = self.blade.space()
        if "L" in space.names:
            i = space.names.index("L")
            return (float(space.lower[i]), float(space.upper[i]))
        return (float(space.fixed["L"]),) if "L" in space.fixed else ()

    def warn_reynolds(self, chord: float) -> None:
        """Issue a :class:`ConfigWarning` if :meth:`reynolds_warning` has one (the commands that solve call
        it; the command line prints it as one ``millfoil: warning:`` line)."""
        text = self.reynolds_warning(chord)
        if text is not None:
            warnings.warn(text, ConfigWarning, stacklevel=2)

    def reynolds_warning(self, chord: float) -> str | None:
        """A sentence if the chord Reynolds number at ``chord`` (m) is outside the range the solver's
        model was validated for (:data:`VALIDATED_REYNOLDS`), else None."""
        lo, hi = VALIDATED_REYNOLDS[self.solver.model]
        re = self.flow.reynolds(chord)
        if lo <= re <= hi:
            return None
        return (f"the chord Reynolds number speed * L * density / viscosity = {re:.3g} is outside [{lo:g}, {hi:g}], "
                f"the range the {self.solver.model} model was validated for: the results are unverified")

    def to_yaml(self) -> str:
        """The resolved configuration as YAML: every value, defaults included, the ``mesh:`` section as
        the full resolved :class:`meshing.MeshSpec` (so that a change of level presets cannot change it);
        reading it back gives the same configuration."""
        data = self.model_dump(mode="json")
        data["mesh"] = dataclasses.asdict(self.mesh_spec())
        return yaml.safe_dump(data, sort_keys=False)


    @classmethod
    def from_mapping(cls, raw: Mapping[str, Any], overrides: Sequence[str] = (), *,
                     values: Mapping[str, Any] | None = None, blade_values: bool = True,
                     source: Source | None = None) -> Self:
        """The configuration of the sections in ``raw`` (as read from YAML), with the ``KEY=VALUE``
        ``overrides`` and then the typed ``values`` (``{dotted key: value}``) set; validated, or
        ConfigError naming the key. The one way to build a configuration (:func:`load_config` reads a
        file into it); a subclass with more sections builds the same way.

        ``blade_values=False`` skips checking ``blade.parameters`` (for commands that need only the space).
        ``source``: where ``raw`` was read (:mod:`optimizer.yamlsource`): messages then start ``FILE:LINE:``.
        """
        data = set_values(apply_overrides(raw, overrides, cls), (values or {}).items(), cls)
        source = source and source.with_overrides(override_items(overrides, cls))
        try:
            config = cls.model_validate(data)
        except ValidationError as exc:
            raise ConfigError(explain(exc, cls, source)) from None
        blade_chord = (lambda: config.check_mesh_for(config.blade.blade_spec().values["L"])) if blade_values else None
        for section, check in (("blade", config.blade.blade_spec if blade_values else None),
                               ("blade", config.blade.space), ("mesh", config.mesh_spec), ("mesh", blade_chord)):
            try:
                if check is not None:
                    check()   # parameter names and domains, the space and the mesh are checked here, once
            except ConfigError as exc:
                raise ConfigError(f"{source.where(_mesh_key(section, exc))}: {exc}" if source else str(exc)) from None
        return config


def _mesh_message(exc: ValueError) -> str:
    """A mesh error as a configuration error: ``mesh.FIELD = ...`` for one field, else ``mesh: ...``."""
    field = getattr(exc, "field", None)
    text = str(exc)
    return f"mesh.{text}" if field is not None and text.startswith(f"{field} ") else f"mesh: {text}"


def _mesh_key(section: str, exc: ConfigError) -> tuple[str, ...]:
    """Where a section's error is: ``("mesh", FIELD)`` when the message names a mesh field, else the section."""
    text = str(exc)
    if section == "mesh" and text.startswith("mesh.") and " " in text:
        return ("mesh", text[len("mesh."):].split(" ", 1)[0])
    return (section,)


def load_config(path: str | Path | None = None, overrides: Sequence[str] = (), *,
                values: Mapping[str, Any] | None = None, schema: type[Config] = Config,
                blade_values: bool = True) -> Config:
    """Read ``path`` (or the embedded defaults if ``None``) into ``schema`` (:class:`Config` or a
    subclass of it), with ``KEY=VALUE`` ``overrides`` and typed ``values`` set: :meth:`Config.from_mapping`."""
    raw, source = read_yaml_source(path, schema) if path is not None else ({}, None)
    return schema.from_mapping(raw, overrides, values=values, blade_values=blade_values, source=source)


def read_yaml(path: str | Path, schema: type[Config] = Config) -> dict[str, Any]:
    """The mapping of sections in the YAML file ``path`` (ConfigError if it cannot be read or is not one)."""
    return read_yaml_source(path, schema)[0]


def read_yaml_source(path: str | Path, schema: type[Config] = Config) -> tuple[dict[str, Any], Source]:
    """:func:`read_yaml` and where each key is (:class:`optimizer.yamlsource.Source`, for error lines).
    An empty file is an error: the embedded defaults are what a command runs without a file."""
    try:
        raw, source = yamlsource.read_yaml(path)
    except yamlsource.YamlSourceError as exc:
        raise ConfigError(str(exc)) from None
    sections = ", ".join(schema.model_fields)
    if raw is None or raw == {}:
        raise ConfigError(f"{path} is empty: a configuration file sets at least one section ({sections}); "
                          "to run the embedded defaults, give no file")
    if not isinstance(raw, dict):
        raise ConfigError(f"{path} must be a YAML mapping of sections ({sections}), not {type(raw).__name__} "
                          f"{shorten(raw)}")
    return raw, source


def apply_overrides(raw: Mapping[str, Any], overrides: Sequence[str], schema: type[Config] = Config) -> dict[str, Any]:
    """A copy of ``raw`` with each ``KEY=VALUE`` set, the value read as YAML (see module docstring) with the
    limits of :mod:`optimizer.yamlsource`; a key given twice is an error."""
    pairs, given = [], {}
    for item in overrides:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ConfigError(f"--set {shorten(item)} must look like KEY=VALUE, e.g. alpha=25 or "
                              "blade.mode=toolpath")
        path = _override_path(key, schema)
        if path in given:
            raise ConfigError(f"--set {_short_key(key)}: the key is given twice ({shorten(given[path])} and "
                              f"{shorten(item)}); give each key once")
        given[path] = item
        try:
            value, _ = yamlsource.parse_yaml(text, f"--set {_short_key(key)}", lines=False)
        except yamlsource.YamlSourceError as exc:
            raise ConfigError(str(exc)) from None
        pairs.append((key, value))
    return set_values(raw, pairs, schema)


def override_items(overrides: Sequence[str], schema: type[Config] = Config) -> dict[tuple[str, ...], str]:
    """``{path: "--set KEY=VALUE"}`` of the (already checked) ``overrides``: where errors about them point."""
    return {_override_path(item.partition("=")[0].strip(), schema): f"--set {_short_key(item.strip())}"
            for item in overrides}


def _short_key(key: str) -> str:
    return key if len(key) <= 60 else key[:59] + "…"


def _override_path(key: str, schema: type[Config]) -> tuple[str, ...]:
    """The path into the configuration of the dotted ``key`` (a bare non-section name is a blade parameter)."""
    path = tuple(key.split("."))
    if any(not part.strip() for part in path):
        raise ConfigError(f"--set {_short_key(key)}: a key is dotted names, e.g. blade.mode or alpha")
    if len(path) == 1 and path[0] not in schema.model_fields:
        names = getattr(schema, "bare_parameter_names", None)
        if names is not None and path[0] not in names:
            raise ConfigError(f"--set {_short_key(key)}: unknown key '{_short_key(key)}'; allowed: "
                              f"{', '.join(schema.model_fields)} (a dotted key into one of them, such as "
                              "mesh.level) or the name of a blade parameter (`millfoil space`)")
        path = ("blade", "parameters", path[0])
    return path



def set_values(raw: Mapping[str, Any], values: Iterable[tuple[str, Any]], schema: type[Config] = Config
               ) -> dict[str, Any]:
    """A copy of ``raw`` with each ``(dotted key, value)`` set; a bare name that is not a section of
    ``schema`` is a blade parameter (``alpha`` is ``blade.parameters.alpha``)."""
    result = copy.deepcopy(dict(raw))
    for key, value in values:
        path = _override_path(key, schema)
        node = result
        for part in path[:-1]:
            child = node.setdefault(part, {})
            if not isinstance(child, dict):
                raise ConfigError(f"--set {shorten(key)}: {shorten(part)} is a value, not a section")
            node = child
        node[path[-1]] = value
    return result


def explain(exc: ValidationError, schema: type[BaseModel], source: Source | None = None) -> str:
    """One line per problem, naming the key and what it allows (and ``FILE:LINE:`` with a ``source``);
    the input is shown shortened (:func:`shorten`). Used for every schema, campaigns included."""
    lines = []
    listed: set[str] = set()

    def allowed(text: str) -> str:
        """The allowed keys, once per message: a second unknown key of the same section says so."""
        if text in listed:
            return "allowed: as above"
        listed.add(text)
        return f"allowed: {text}"

    for err in exc.errors():
        loc = tuple(p for p in err["loc"] if not (isinstance(p, str) and "[" in p))   # drop validator tags
        error = (err.get("ctx") or {}).get("error")
        loc = (*loc, *getattr(error, "path", ()))             # where below the field (e.g. a boolean)
        msg = err["msg"].removeprefix("Value error, ")
        where = ".".join(str(p) for p in loc)
        at = f"{source.where(loc)}: " if source is not None else ""
        if err["type"] == "unknown_key":
            lines.append(f"{at}unknown key '{where}'; {allowed(err['ctx']['allowed'])}")
        elif err["type"] == "extra_forbidden":
            lines.append(f"{at}unknown key '{where}'; {allowed(', '.join(_allowed_keys(schema, loc[:-1])))}")
        elif err["type"] in ("enum", "literal_error"):
            lines.append(f"{at}'{where}' = {shorten(err['input'])} is not allowed; allowed: {err['ctx']['expected']}")
        elif err["type"] == "missing":
            lines.append(f"{at}'{where}' is required")
        elif isinstance(error, _BooleanForNumber):
            lines.append(f"{at}'{where}': {error}")
        elif (text := range_error(err, loc, schema)) is not None:
            lines.append(f"{at}{text}")
        else:
            lines.append(f"{at}'{where}': {msg} (got {shorten(err['input'])})")
    return "; ".join(lines)


_RANGE_ERRORS = ("greater_than", "greater_than_equal", "less_than", "less_than_equal")


def range_error(err: Mapping[str, Any], loc: Sequence[Any], schema: type[BaseModel]) -> str | None:
    """``'KEY' = VALUE is outside [LOW, HIGH]: WHY`` for a pydantic error ``err`` of a value out of its
    bounds at ``loc`` (the field's ``ge``/``gt``/``le``/``lt``, and the ``why`` of its ``json_schema_extra``),
    else None."""
    if err["type"] not in _RANGE_ERRORS:
        return None
    info = _field_at(schema, loc)
    if info is None:
        return None
    lower, upper = "(-inf", "inf)"
    for m in info.metadata:
        for name, text in (("gt", "({}"), ("ge", "[{}"), ("lt", "{})"), ("le", "{}]")):
            if getattr(m, name, None) is not None:
                bound = text.format(_number(getattr(m, name)))
                lower, upper = (bound, upper) if name[0] == "g" else (lower, bound)
    extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
    unit = f" {extra['unit']}" if extra.get("unit") else ""
    why = f": {extra['why']}" if extra.get("why") else ""
    return f"'{'.'.join(str(p) for p in loc)}' = {_number(err['input'])}{unit} is outside {lower}, {upper}{unit}{why}"


def _number(value: Any) -> str:
    """A number as a user reads it (``1e-300``, ``100000``, ``1e+90``); other input shortened."""
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            return shorten(value)
    if isinstance(value, int) and not isinstance(value, bool):
        digits = str(abs(value))
        return str(value) if len(digits) < 16 else f"{'-' * (value < 0)}{digits[0]}.{digits[1:4]}e+{len(digits) - 1}"
    return f"{value:g}" if isinstance(value, float) and math.isfinite(value) else shorten(value)


def _field_at(schema: type[BaseModel], loc: Sequence[Any]) -> Any:
    """The pydantic FieldInfo at ``loc`` (section models followed), or None."""
    model, info = schema, None
    for part in loc:
        fields = getattr(model, "model_fields", None)
        if not isinstance(fields, dict) or str(part) not in fields:
            return None
        info = fields[str(part)]
        model = info.annotation
    return info


def _allowed_keys(schema: type[BaseModel], loc: Sequence[Any]) -> list[str]:
    """The keys allowed at ``loc`` in ``schema`` (following sections, lists and optional sections)."""
    model = schema
    for part in loc:
        if isinstance(part, int):
            continue
        field = model.model_fields.get(str(part))
        if field is None:
            break
        candidates = [field.annotation, *get_args(field.annotation)]
        candidates += [a for c in list(candidates) for a in get_args(c)]
        nested = [c for c in candidates if isinstance(c, type) and issubclass(c, BaseModel)]
        if not nested:
            break
        model = nested[0]
    return list(model.model_fields)
