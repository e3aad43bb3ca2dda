"""Few-shot localization: a classifier image -> node trained on a solution's labels, its
checkpoints, and planning from a start and a goal image.

``train_localizer(trace, solution)`` cross-validates learning rate and epochs, fits on all
observations and returns a :class:`Localizer`; :func:`save_localizer` / :func:`load_localizer`
write and read checkpoints that load with ``torch.load(weights_only=True)``;
:func:`plan_images` localizes two images and plans between their nodes. Evaluation against
ground truth (localization accuracy, I2P, Exec-I2P) lives in :mod:`vggc_cp.evaluate.i2p`.
"""

from vggc_cp.localize.backbones import BACKBONES, DEFAULT_BACKBONE, backbone_names
from vggc_cp.localize.localizer import (
    CheckpointError,
    ImageError,
    Localizer,
    Prediction,
    load_localizer,
    read_image,
    save_localizer,
    solution_digest,
    write_image,
)
from vggc_cp.localize.model import Augment, CosineHead, LocalizerNet
from vggc_cp.localize.planning import (
    ImagePlan,
    check_model_matches,
    plan_between,
    plan_images,
    solution_graph,
)
from vggc_cp.localize.train import TrainConfig, TrainReport, quick_config, train_localizer

__all__ = ["BACKBONES", "DEFAULT_BACKBONE", "Augment", "CheckpointError", "CosineHead",
           "ImageError", "ImagePlan", "Localizer", "LocalizerNet", "Prediction", "TrainConfig",
           "TrainReport", "backbone_names", "check_model_matches", "load_localizer",
           "plan_between", "plan_images", "quick_config", "read_image", "save_localizer",
           "solution_digest", "solution_graph", "train_localizer", "write_image"]
