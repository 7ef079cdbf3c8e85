"""Generate a directory of annotated scenes (``samplehd scenes``).

Layout of DIR::

    config.json              fully resolved configuration (sampler, resolution, preset, seed)
    scenes.json              CLEVR layout: {info, scenes: [...]} sorted by image_index
    scenes/<stem>.json       one scene annotation each
    images/<stem>.png        RGB from the scene camera
    depth/<stem>.png         depth as uint16 millimetres; depth/<stem>.npy the exact float32 metres
    segmentation/<stem>.png  instance ids (0 background, 1 table, 2 robot, 3 + i object i)

``<stem>`` is ``SHD_<split>_<index:06d>``. Scene ``i`` is drawn from ``scene_seed(seed, i)`` alone, so the
result does not depend on the number of workers.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from samplehd.errors import ConfigError
from samplehd.fileio import write_json_atomic
from samplehd.render.image_io import save_depth, save_rgb, save_segmentation
from samplehd.render.image_spec import ImageSpec
from samplehd.render.photo import PhotoOptions, photo_info, photo_options
from samplehd.render.renderer import MODALITIES, get_preset
from samplehd.render.renderer_cache import RendererCache
from samplehd.scene.annotate import annotate_scene, image_stem
from samplehd.scene.config import SceneConfig
from samplehd.scene.sampler import sample_scene
from samplehd.scene.spec import compile_scene
from samplehd.scene.world import fresh_state
from samplehd.version import __version__
from samplehd.workers import Backend
from samplehd.world.seeding import scene_seed

__all__ = ["SceneJob", "generate_scenes", "render_scene_files", "scene_split"]


def scene_split(index: int, test_every: int = 20) -> str:
    """Split of scene `index`: every `test_every`-th scene is in the test split (5 % by default)."""
    return "test" if test_every > 0 and index % test_every == test_every - 1 else "train"


@dataclass(frozen=True)
class SceneJob:
    """Everything a worker needs to make one scene's files.

    Attributes:
        index: the scene's index.
        seed: the scene's seed (``scene_seed(seed, index)``).
        out: the scenes or dataset folder.
        config: the scene sampler's options.
        image: size, render preset and modalities of the scene camera's images (the files show the
            ``scene`` camera only; a modality left out gets no file).
        test_every: every this many scenes one is in the test split.
        photo_look: ``fixed`` or ``random`` (the photo preset's look).
    """

    index: int
    seed: int
    out: str
    config: SceneConfig
    image: ImageSpec
    test_every: int
    photo_look: str = "fixed"

    def __post_init__(self) -> None:
        if self.image.cameras != ("scene",):
            raise ConfigError(f"image.cameras={list(self.image.cameras)!r}: a scene's files show the scene "
                              "camera only; ask for ['scene']")


def render_scene_files(job: SceneJob) -> tuple[dict[str, Any], dict[str, int]]:
    """Sample, render and annotate one scene; writes its files and returns (annotation, rejections)."""

    image = job.image
    # The occlusion check and the images share one model and, when their presets agree, its renderer.
    with RendererCache(buffer_size=(image.width, image.height)) as renderers:
        result = sample_scene(job.index, job.seed, job.config, renderers=renderers)
        if result.model is not None:
            model, data = result.model, fresh_state(result.model)
        else:
            model, data = compile_scene(result.scene)
        photo = _photo(job)
        img = renderers.get(model, image, photo=photo).render(data, "scene", image.modalities)
    split = scene_split(job.index, job.test_every)
    stem = image_stem(split, job.index)
    out = Path(job.out)
    if "rgb" in img:
        save_rgb(out / "images" / f"{stem}.png", img["rgb"])
    if "depth" in img:
        save_depth(out / "depth" / f"{stem}.png", img["depth"])
        save_depth(out / "depth" / f"{stem}.npy", img["depth"])
    if "segmentation" in img:
        save_segmentation(out / "segmentation" / f"{stem}.png", img["segmentation"])
    ann = annotate_scene(result.scene, model, data, image.width, image.height, split=split)
    ann["sampling"] = {"attempts": result.attempts, "rejections": dict(result.rejections),
                       "visible_pixels": result.visible_pixels}
    if photo is not None:  # the path tracer's settings and the (possibly randomised) look of this scene
        ann["render"] = {"preset": image.preset, "photo": photo_info(photo)}
    write_json_atomic(out / "scenes" / f"{stem}.json", ann)
    return ann, dict(result.rejections)


def _photo(job: SceneJob) -> PhotoOptions | None:
    """The photo options of a scene (its look drawn from its seed when randomised), or None for GL presets."""
    if not get_preset(job.image.preset).path_traced:
        return None
    return photo_options(job.photo_look, job.seed, where="photo_look")


def generate_scenes(
    out: Path,
    num: int,
    seed: int = 0,
    config: SceneConfig | None = None,
    image: ImageSpec | None = None,
    workers: int = 1,
    test_every: int = 20,
    on_scene: Callable[[int], None] | None = None,
    photo_look: str = "fixed",
) -> dict[str, Any]:
    """Sample `num` scenes into `out` and write scenes.json; returns a summary with rejection counts.
    ``image``: the scene camera's images (default: 640×360, ``fast``, every modality; see :class:`SceneJob`).
    ``photo_look`` (preset photo): ``fixed``, or ``random`` to draw each scene's look from its seed."""

    if num < 1:
        raise ConfigError(f"num={num}: must be ≥ 1", field="num")
    backend = Backend(workers=workers)
    image = image or ImageSpec(640, 360, "fast", modalities=MODALITIES)
    if get_preset(image.preset).path_traced:
        photo_options(photo_look, 0, where="photo_look")  # validate before writing anything
    config = config or SceneConfig()
    try:
        for sub in ("scenes", "images", "depth", "segmentation"):
            (out / sub).mkdir(parents=True, exist_ok=True)
        probe = out / ".write_test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        raise ConfigError(f"output directory {out} is not writable: {exc.strerror}") from exc
    resolved = {"scene": config.to_dict(), "num": num, "seed": seed, "width": image.width, "height": image.height,
                "preset": image.preset, "test_every": test_every, "version": __version__}
    if photo_look != "fixed":
        resolved["photo_look"] = photo_look
    write_json_atomic(out / "config.json", resolved, indent=2)
    # Made one at a time as workers take them (a large `num` holds no list of jobs in memory).
    jobs = (SceneJob(i, scene_seed(seed, i), str(out), config, image, test_every, photo_look) for i in range(num))
    scenes: list[dict[str, Any]] = []
    rejections: Counter[str] = Counter()
    for _, (ann, rej) in backend.map(render_scene_files, jobs):
        scenes.append(ann)
        rejections.update(rej)
        if on_scene:
            on_scene(len(scenes))
    scenes.sort(key=lambda s: s["image_index"])
    info = {"version": __version__, "seed": seed, "num_scenes": num, "license": "CC BY 4.0",
            "split_rule": f"every {test_every}th scene is test"}
    write_json_atomic(out / "scenes.json", {"info": info, "scenes": scenes})
    return {"scenes": num, "rejections": dict(sorted(rejections.items())),
            "attempts": sum(s["sampling"]["attempts"] for s in scenes)}
