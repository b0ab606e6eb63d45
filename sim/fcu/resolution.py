"""Module dependency resolution: seed 002, Algorithm 1 (two-pass sort) and Algorithm 2.

Pass 1 walks explicit module dependencies depth first (Algorithm 2), pulling in modules
the user did not select and storing ``@functionality`` and ``a|b`` requirements, conflicts
and provided functionalities for later. Algorithm 1 then checks conflicts and missing
functionalities, substitutes each functionality or alternative with the resolved modules
that satisfy it, and runs a second, simpler pass over the same modules so that a module
is placed after everything it depends on, including through functionalities.

Algorithm 2's "if m is valid for firmware and target" test is not modelled: every
declared module is valid for our single simulated target.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from sim.fcu.errors import (
    ConflictError,
    DependencyCycleError,
    MissingFunctionalityError,
    ModuleSpecError,
)
from sim.fcu.modules import AnyOf, FunctionalityRef, ModuleRef, ModuleSpec, Requirement

SELECTION = "<selection>"
"""Name of the seed's synthetic *root* module, whose dependencies are the user's choice."""


@dataclass
class _Pass1:
    """Algorithm 2's lists: resolved, unresolved, required, conflict and provided."""

    catalogue: Mapping[str, ModuleSpec]
    roots: tuple[str, ...]
    resolved: list[str] = field(default_factory=list)
    resolved_set: set[str] = field(default_factory=set)
    unresolved: list[str] = field(default_factory=list)
    required: list[tuple[str, FunctionalityRef | AnyOf]] = field(default_factory=list)
    conflicts: list[tuple[str, ModuleRef | FunctionalityRef]] = field(default_factory=list)
    provided: dict[str, list[str]] = field(default_factory=dict)  # functionality -> modules

    def requirements(self, name: str) -> tuple[Requirement, ...]:
        if name == SELECTION:
            return tuple(ModuleRef(n) for n in self.roots)
        return self.catalogue[name].requirements()


def index_modules(modules: Iterable[ModuleSpec]) -> dict[str, ModuleSpec]:
    """Modules by name, in declaration order; duplicate names are an error."""
    catalogue: dict[str, ModuleSpec] = {}
    for i, module in enumerate(modules):
        if not isinstance(module, ModuleSpec):
            raise ModuleSpecError(f"modules[{i}]", f"expected a ModuleSpec, got {module!r}")
        if module.name in catalogue:
            raise ModuleSpecError(f"modules[{i}].name", f"duplicate module {module.name!r}")
        catalogue[module.name] = module
    return catalogue


def sort_modules(
    modules: Iterable[ModuleSpec], selected: Sequence[str] | None = None
) -> tuple[ModuleSpec, ...]:
    """Algorithm 1 (SORT MODULES): the selected modules and their dependencies, ordered.

    ``modules`` is the catalogue of declared modules; ``selected`` the user's choice (the
    seed's airframe and flight plan), by default every declared module in declaration
    order. Returns the fully ordered list: each module comes after the modules it depends
    on, directly or through a functionality or alternative. The order is not unique; as
    in the seed the first valid one (depth first, declaration order) is kept.

    Raises DependencyCycleError, ConflictError or MissingFunctionalityError.
    """
    catalogue = index_modules(modules)
    # Algorithm 1: "extract list of modules selected by user", "add them to a root module"
    roots = tuple(catalogue) if selected is None else tuple(selected)
    state = _Pass1(catalogue, roots)
    # Algorithm 1: "RESOLVE(root)", the first pass of Algorithm 2
    _resolve_pass1(state, SELECTION)
    resolved = state.resolved_set - {SELECTION}
    _check_conflicts(state, resolved)
    # Algorithm 1: "if not all required modules and functionalities are in provided list"
    for requirer, req in state.required:
        if not _satisfiers(req, requirer, resolved, state.provided):
            raise MissingFunctionalityError(requirer, str(req), _candidates(req, catalogue))
    # Algorithm 1: "substitute functionalities or logical expression with proper modules
    # from resolved list"
    edges: dict[str, tuple[str, ...]] = {}
    for name in state.resolved:
        deps: list[str] = []
        for dep in state.requirements(name):
            if isinstance(dep, ModuleRef):
                deps.append(dep.name)
            else:
                found = _satisfiers(dep, name, resolved, state.provided)
                deps.extend(d for d in found if d != name)
        edges[name] = tuple(dict.fromkeys(deps))
    # Algorithm 1: "RESOLVE(root (updated))", the second pass: no new module, no check
    order: list[str] = []
    _resolve_pass2(edges, SELECTION, order, set(), [])
    return tuple(catalogue[name] for name in order if name != SELECTION)


def _resolve_pass1(state: _Pass1, name: str) -> None:
    """Algorithm 2, RESOLVE(m), first pass.

    "add m to unresolved; for each dependency d in m: if d is a module and not in
    resolved: if d is in unresolved, fail (cyclic dependency) else RESOLVE(d); else (a
    functionality or logical expression) add d to required list. Add conflicts and
    provided to their lists, add m to resolved, remove m from unresolved."
    """
    state.unresolved.append(name)
    for dep in state.requirements(name):
        if isinstance(dep, ModuleRef):
            if dep.name in state.resolved_set:
                continue
            if dep.name in state.unresolved:
                raise DependencyCycleError(_cycle(state.unresolved, dep.name))
            if dep.name not in state.catalogue:
                raise MissingFunctionalityError(name, dep.name)
            _resolve_pass1(state, dep.name)
        else:
            state.required.append((name, dep))
    if name != SELECTION:
        module = state.catalogue[name]
        state.conflicts.extend((name, ref) for ref in module.conflict_refs())
        for functionality in module.functionalities():
            state.provided.setdefault(functionality, []).append(name)
    state.resolved.append(name)
    state.resolved_set.add(name)
    state.unresolved.pop()


def _check_conflicts(state: _Pass1, resolved: set[str]) -> None:
    """Algorithm 1's two conflict checks, in the seed's order.

    1. "if at least a module from resolved in conflict list then fail".
    2. "if at least a functionality from required in conflict list then fail"; a
       functionality that another resolved module provides is brought in just the
       same and fails too. ``conflicts: [@f]`` on a provider of ``f`` reads "the only
       provider of f", so it does not clash with modules that require ``f``.
    """
    for module, ref in state.conflicts:
        if isinstance(ref, ModuleRef) and ref.name in resolved and ref.name != module:
            raise ConflictError(module, ref.name, ref.name)
    for module, ref in state.conflicts:
        if not isinstance(ref, FunctionalityRef):
            continue
        providers = state.provided.get(ref.name, [])
        for provider in providers:
            if provider != module:
                raise ConflictError(module, provider, str(ref))
        if module in providers:
            continue
        for requirer, req in state.required:
            if req == ref and requirer != module:
                raise ConflictError(module, requirer, str(ref))


def _resolve_pass2(
    edges: Mapping[str, tuple[str, ...]],
    name: str,
    resolved: list[str],
    resolved_set: set[str],
    unresolved: list[str],
) -> None:
    """Algorithm 2, RESOLVE(m), second pass over the substituted dependencies.

    Same depth-first walk; every dependency is now a resolved module, so this pass only
    orders them and detects cycles that go through functionalities.
    """
    unresolved.append(name)
    for dep in edges[name]:
        if dep in resolved_set:
            continue
        if dep in unresolved:
            raise DependencyCycleError(_cycle(unresolved, dep))
        _resolve_pass2(edges, dep, resolved, resolved_set, unresolved)
    resolved.append(name)
    resolved_set.add(name)
    unresolved.pop()


def _cycle(unresolved: Sequence[str], again: str) -> tuple[str, ...]:
    """The cycle closed by reaching ``again`` while it is still unresolved."""
    start = list(unresolved).index(again)
    return (*unresolved[start:], again)


def _satisfiers(
    req: FunctionalityRef | AnyOf,
    requirer: str,
    resolved: set[str],
    provided: Mapping[str, Sequence[str]],
) -> tuple[str, ...]:
    """The resolved modules that satisfy ``req`` (empty if none does).

    ``@f`` is satisfied by every resolved provider of ``f`` other than the requirer
    itself, in resolution order (the requirer runs after all of them); ``a|@b|c`` by
    its first satisfied option, in declaration order.
    """
    if isinstance(req, FunctionalityRef):
        providers = provided.get(req.name, ())
        if requirer in providers:
            return tuple(p for p in providers if p != requirer) or (requirer,)
        return tuple(providers)
    for option in req.options:
        if isinstance(option, ModuleRef):
            if option.name in resolved:
                return (option.name,)
        elif found := _satisfiers(option, requirer, resolved, provided):
            return found
    return ()


def _candidates(req: Requirement, catalogue: Mapping[str, ModuleSpec]) -> tuple[str, ...]:
    """Declared modules that would satisfy ``req`` if they were selected."""
    options = req.options if isinstance(req, AnyOf) else (req,)
    found: list[str] = []
    for option in options:
        if isinstance(option, ModuleRef):
            if option.name in catalogue:
                found.append(option.name)
        else:
            found.extend(m.name for m in catalogue.values() if option.name in m.functionalities())
    return tuple(dict.fromkeys(found))
