"""The scene and parameters in force, and every change to them.

A change -- a new scene from a control request, new material parameters, a
SIGHUP reload -- has a slow part that may fail on user input (reading the
file, compiling the scene, checking that what it will publish can be
encoded) and a swap that cannot. `SceneState` keeps them apart: the
`prepare_*` and `load_*` methods run on any thread and apply nothing;
`apply_pipeline` swaps a prepared pipeline in, and runs only on the loop
thread between ticks, either from a control request answered there or from
a task `post`-ed to the loop and run by `run_tasks`. A refused change is
counted and leaves the running scene untouched.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from stiction import protocol
from stiction.daemon.config import load_options
from stiction.daemon.device_set import DeviceSet
from stiction.daemon.options import Options
from stiction.daemon.wake import Waker
from stiction.errors import SceneError, StictionError
from stiction.scene.backend import SimulatorBackend
from stiction.scene.load import default_scene, load_scene, parse_scene
from stiction.scene.model import Scene
from stiction.scene.pipeline import Pipeline

SNAPSHOT_ROOM = 64 << 10
"""Bytes left beside a scene in a message for the latest frame of each device: a
snapshot carries both, and clients refuse any message over MAX_MESSAGE_BYTES."""

log = logging.getLogger("stiction.daemon")  # the loop's logger: log lines keep their name


class SceneState:
    """The running pipeline with its defaults, the changes to it, and their counts."""

    def __init__(
        self,
        opts: Options,
        devices: DeviceSet,
        waker: Waker,
        *,
        publish: Callable[[], None],
        last_tick: Callable[[], int],
        reload_keys: Callable[[], None],
    ) -> None:
        """`publish` sends the scene message of the pipeline just swapped in;
        `last_tick` is the loop's last tick number (a scene message carries
        one); `reload_keys` re-reads the CURVE keys when a reload re-read the
        config file. A scene named in `opts` that cannot be loaded is raised."""
        self.opts = opts
        self.devices = devices
        self.waker = waker
        self._publish = publish
        self._last_tick = last_tick
        self._reload_keys = reload_keys
        self.backend = SimulatorBackend(opts.integrator, opts.substeps)
        self.defaults: dict[str, Any] = {
            **self.backend.defaults(),
            **opts.params,
            "rate": opts.rate,
        }
        scene = load_scene(opts.scene) if opts.scene else default_scene(opts.display)
        self.pipeline = self._checked(Pipeline(scene, self.backend, self.defaults))
        self.counters = {"scene_loads": 1, "scene_errors": 0, "reloads": 0}
        self.generation = 0
        """Counts pipeline swaps (a change prepared against an older pipeline is redone)."""
        self.tasks: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
        """Changes waiting for the loop's next tick boundary (`post`, `run_tasks`)."""
        self._stopped = threading.Event()
        self._reload_worker: threading.Thread | None = None
        self._reload_wanted = threading.Event()

    # ------------------------------------------------------------ prepare (any thread)
    def prepare_scene(
        self, scene: Scene, defaults: dict[str, Any] | None = None, *, count: bool = True
    ) -> Pipeline:
        """Compile `scene` and check that what it will publish can be encoded; apply nothing.

        Safe off the loop thread: it reads the current pipeline only for the tick
        number. A refused scene is counted and leaves the running one untouched.
        """
        try:
            pipeline = self._checked(
                Pipeline(scene, self.backend, self.defaults if defaults is None else defaults)
            )
        except StictionError:
            if count:
                self.counters["scene_errors"] += 1
            raise
        return pipeline

    def _checked(self, pipeline: Pipeline) -> Pipeline:
        """`pipeline`, once every material's parameters suit the integrator (else ParamError):
        an explicit integrator with a stiff material (set_params k=1e4) was swapped in
        and then failed every tick; and once what it will publish fits the wire."""
        for params in (*pipeline.params.values(), *pipeline.frictionless.values()):
            self.backend.check(params)
        wire = pipeline.wire()
        scene = pipeline.scene
        sizes = (
            # the largest tick a message may carry: its msgpack size is the bound
            ("scene message", protocol.scene_message(wire, 2**63 - 1), SNAPSHOT_ROOM),
            ("get_scene reply", protocol.scene_reply(wire, scene.text), 0),
        )
        for what, message, room in sizes:
            size = len(protocol.encode(message))
            if size > protocol.MAX_MESSAGE_BYTES - room:
                raise SceneError(
                    f"{scene.source}: its {what} would be {size} bytes; clients accept "
                    f"{protocol.MAX_MESSAGE_BYTES} (docs/protocol.md), less {room} for frames "
                    "beside it: use fewer polygon points or regions"
                    if room
                    else f"{scene.source}: its {what} would be {size} bytes; clients accept "
                    f"{protocol.MAX_MESSAGE_BYTES} (docs/protocol.md): use fewer polygon "
                    "points or regions"
                )
        return pipeline

    def load_scene_text(self, text: str, source: str) -> Scene:
        try:
            return parse_scene(text, source)
        except StictionError:
            self.counters["scene_errors"] += 1
            raise

    def load_scene_file(self, path: Path) -> Scene:
        try:
            return load_scene(path)
        except StictionError:
            self.counters["scene_errors"] += 1
            raise

    def prepare_params(
        self, values: dict[str, Any], material: str | None
    ) -> tuple[Pipeline, dict[str, Any]]:
        """The pipeline and defaults with `values` applied, checked; refused as a whole."""
        from stiction.daemon.params import apply_params

        scene, defaults = apply_params(self.pipeline.scene, self.defaults, values, material)
        return self.prepare_scene(scene, defaults, count=False), defaults

    # ------------------------------------------------------------ apply (loop thread)
    def apply_pipeline(self, pipeline: Pipeline, defaults: dict[str, Any] | None = None) -> None:
        """Switch to a prepared pipeline (loop thread): nothing here can fail on user input."""
        old_display = self.pipeline.scene.display
        scene = pipeline.scene
        self.pipeline = pipeline
        if defaults is not None:
            self.defaults = defaults
        self.counters["scene_loads"] += 1
        self.generation += 1
        if scene.display != old_display:
            self.devices.remap(scene.display)
        log.info("scene_loaded name=%s source=%s", scene.name, scene.source)
        self._publish()

    def set_scene(self, scene: Scene) -> None:
        """Compile and switch to `scene`; on any error the current scene stays."""
        self.apply_pipeline(self.prepare_scene(scene))

    def set_params(self, values: dict[str, Any], material: str | None) -> None:
        """Change material parameters; refused as a whole if any value is invalid."""
        self.apply_pipeline(*self.prepare_params(values, material))
        self.log_params(values, material)

    def log_params(self, values: dict[str, Any], material: str | None) -> None:
        log.info("params_set material=%s values=%s", material, values)

    def post(self, task: Callable[[], None]) -> None:
        """Run `task` on the loop thread at the next tick boundary."""
        self.tasks.put(task)
        self.waker.wake()

    def run_tasks(self) -> None:
        """Run every posted task (loop thread, between ticks)."""
        while not self.tasks.empty():
            task = self.tasks.get_nowait()
            try:
                task()
            except Exception:  # a bug in one task must not stop the loop
                log.exception("task_failed")

    # ------------------------------------------------------------ reload (SIGHUP)
    def reload(self) -> None:
        """SIGHUP: re-read the config's run-time settings and the scene; keep them on error.

        Runs on the caller's thread (a reload worker, not the loop): files are
        read and the scene compiled here, and only the swap is posted to the loop.
        """
        # `reloads` counts finished reloads (refused or applied), so a client
        # that sees it move also sees the outcome.
        opts = self.opts
        params = opts.params
        scene_path = opts.scene
        if opts.config_path is not None:
            try:
                new = load_options(opts.config_path)
            except StictionError as exc:
                log.error("reload_failed config=%s error=%s", opts.config_path, exc)
                self.counters["reloads"] += 1
                return
            if new.scene is not None and not opts.scene_from_flag:
                scene_path = new.scene
            params = new.params
        try:
            scene = (
                self.load_scene_file(scene_path)
                if scene_path
                else default_scene(self.pipeline.scene.display)
            )
            defaults = {**self.backend.defaults(), **params, "rate": opts.rate}
            pipeline = self.prepare_scene(scene, defaults)
        except StictionError as exc:
            log.error(
                "reload_failed scene=%s error=%s (keeping the current scene)", scene_path, exc
            )
            self.counters["reloads"] += 1
            return

        def swap() -> None:
            opts.scene, opts.params = scene_path, params
            if opts.config_path is not None:
                self._reload_keys()
            self.apply_pipeline(pipeline, defaults)
            self.counters["reloads"] += 1

        self.post(swap)

    def start_reload(self) -> None:
        """Read and compile off the loop thread, on one long-lived reload thread.

        One thread for every SIGHUP rather than a new one each: a storm of
        signals costs no thread churn. Requests that come while a reload runs
        are coalesced into one more.
        """
        self._reload_wanted.set()
        if self._reload_worker is None:

            def work() -> None:
                while not self._stopped.is_set():
                    self._reload_wanted.wait()
                    self._reload_wanted.clear()
                    if self._stopped.is_set():
                        return
                    try:
                        self.reload()
                    except Exception:
                        log.exception("reload_failed")

            self._reload_worker = threading.Thread(target=work, name="reload", daemon=True)
            self._reload_worker.start()

    def stop(self) -> None:
        """The daemon is stopping: the reload thread ends instead of waiting for a SIGHUP."""
        self._stopped.set()
        self._reload_wanted.set()
