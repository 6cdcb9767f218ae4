"""Plugin registries as Nav2's pluginlib keeps them: a plugin type name -> its parameters and its code.

Nav2 loads costmap layers, planners, controllers and goal checkers by the type name a parameter file
gives (``plugin: nav2_costmap_2d::InflationLayer``). Each navlog plugin module holds its parameter
dataclass and its code; a ``PluginRegistry`` maps the type names to both. A name maps to:

- a ``Plugin`` with an implementation: navlog reads, checks and runs it;
- a ``Plugin`` without one: navlog reads and checks its parameters, but does not run it (yet);
- ``None``: a plugin Nav2 knows that navlog neither reads nor runs (its section is not checked).

Names are looked up in Nav2's current spelling ``package::Class``; Humble's ``package/Class`` is
accepted as the same name (``normalize_plugin``).

A plugin's parameter dataclass derives from ``PluginParams``: ``read_section`` builds it from the
plugin's YAML section, and a plugin whose parameters need more than the field-by-field reading (the
obstacle layer's observation sources) overrides it. ``read_plugin_type`` and ``read_plugin_list``
read the plugin sections a node lists, each as its registered type.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from navlog.errors import ConfigError
from navlog.replay.config import suggest
from navlog.replay.nav2.schema import ERROR, NOTE, SectionReader

T = TypeVar("T")


def normalize_plugin(name: str) -> str:
    """'pkg/Class' (Humble and older) -> 'pkg::Class'."""
    return (
        name.replace("/", "::") if "::" not in name and name.count("/") == 1 and not name.startswith("spatio") else name
    )


class PluginParams:
    """Base of a plugin's parameter dataclass (it adds no field): how the plugin's section is read."""

    @classmethod
    def read_section(cls, r: SectionReader, section: Any, path: tuple, plugin: str) -> Any:
        """The parameters of plugin type ``plugin`` from its YAML ``section`` (problems go to ``r``).

        Every key of the section is taken as the plugin's own.
        """
        return r.read(cls, section, path, extra={"plugin": plugin})

    @classmethod
    def read_loaded(cls, r: SectionReader, section: Any, path: tuple, plugin: str) -> Any:
        """As ``read_section``, for a plugin Nav2 loads: one that loads plugins of its own (MPPI's
        critics) also reads their sections, which sit inside its own.
        """
        return cls.read_section(r, section, path, plugin)


@dataclass(frozen=True)
class Plugin(Generic[T]):
    """One registered plugin type: the dataclass its section is read into, and the class that runs it."""

    params: type[PluginParams]
    implementation: type[T] | None = None  # None: parameters read and checked, not run by navlog


class PluginRegistry(Mapping[str, Plugin[T] | None], Generic[T]):
    """Plugin type name -> ``Plugin`` (or None: known to Nav2, not read by navlog), in registration order."""

    def __init__(self, kind: str, plugins: Mapping[str, Plugin[T] | None]) -> None:
        self.kind = kind  # "costmap layer", "planner", ...: how errors name a plugin of this registry
        self._plugins = dict(plugins)

    def __getitem__(self, name: str) -> Plugin[T] | None:
        return self._plugins[normalize_plugin(name)]

    def __iter__(self) -> Iterator[str]:
        return iter(self._plugins)

    def __len__(self) -> int:
        return len(self._plugins)

    def with_params(self) -> list[str]:
        """The names whose parameters navlog reads (implemented or not)."""
        return [name for name, plugin in self._plugins.items() if plugin is not None]

    def implementation(self, name: str) -> type[T]:
        """The class that runs plugin type ``name``; ConfigError (with a did-you-mean) when there is none."""
        if name not in self:
            raise ConfigError(f"unknown {self.kind} plugin '{name}'{suggest(normalize_plugin(name), self)}")
        plugin = self[name]
        if plugin is None or plugin.implementation is None:
            runnable = [n for n, p in self._plugins.items() if p is not None and p.implementation is not None]
            raise ConfigError(
                f"{self.kind} plugin '{name}' is read, not implemented by navlog; implemented: {', '.join(runnable)}"
            )
        return plugin.implementation

    def create(self, name: str, *args: Any, **kwargs: Any) -> T:
        """An instance of plugin type ``name`` built with ``args`` (see ``implementation`` for the errors)."""
        return self.implementation(name)(*args, **kwargs)


# ---------------------------------------------------------------- reading plugin sections


def read_plugin_type(
    r: SectionReader, section: Any, path: tuple, registry: PluginRegistry, default: str | None
) -> tuple[str | None, type[PluginParams] | None]:
    """(normalized plugin type, its parameter class) of a plugin section, or None where it has none.

    An unknown type is one error with a did-you-mean; the section's other keys are not checked (checked
    as a guessed plugin, they would bring did-you-means of that plugin's keys, wrong if the guess is). A type Nav2 knows and navlog does not read
    is noted: (type, None).
    """
    kind = registry.kind
    ptype = section.get("plugin") if isinstance(section, dict) else None
    if ptype is None:
        if default is None:
            r.add(ERROR, path, f"{kind} has no 'plugin' parameter")
            return None, None
        ptype = default
    if not isinstance(ptype, str):
        r.add(ERROR, path + ("plugin",), f"expected a plugin name string, got {ptype!r}")
        return None, None
    norm = normalize_plugin(ptype)
    if norm not in registry:
        # one error for the section: its keys are not checked against a plugin it may not have meant
        others = [k for k in section if k != "plugin"] if isinstance(section, dict) else []
        skipped = f"; its {len(others)} other key(s) are not checked until the type is fixed" if others else ""
        r.add(
            ERROR,
            path + ("plugin",),
            f"unknown {kind} plugin '{ptype}'{suggest(norm, registry)}; Nav2 fails to load it at launch{skipped}",
        )
        return None, None
    plugin = registry[norm]
    if plugin is None:
        r.add(NOTE, path + ("plugin",), f"{kind} plugin '{norm}' is read, not implemented by navlog")
        return norm, None
    return norm, plugin.params


def read_plugin_list(
    r: SectionReader,
    params: dict,
    path: tuple,
    list_key: str,
    registry: PluginRegistry,
    default_names: list[str],
    default_type: str,
) -> dict[str, Any]:
    """The plugins a server lists under ``list_key`` (each with its section), by name, read as their types.

    When the list is Nav2's default (or absent), a section without ``plugin`` is of ``default_type``.
    """
    kind = registry.kind
    names = params.get(list_key, default_names)
    if isinstance(names, str):
        names = [names]
    if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
        return {}
    out = {}
    for name in names:
        ppath = path + (name,)
        sec = params.get(name)
        dtype = default_type if (list_key not in params or params.get(list_key) == list(default_names)) else None
        if sec is None and dtype is None:
            sections = [k for k, v in params.items() if isinstance(v, dict)]
            r.add(
                ERROR,
                path + (list_key,),
                f"{kind} '{name}' is listed but has no '{name}:' section{suggest(name, sections)}",
            )
            continue
        sec = sec if isinstance(sec, dict) else {}
        norm, cls = read_plugin_type(r, sec, ppath, registry, dtype)
        if cls is None or norm is None:
            continue
        out[name] = cls.read_loaded(r, sec, ppath, norm)
    return out
