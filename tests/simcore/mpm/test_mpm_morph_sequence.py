import numpy as np

from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_morph_sequence import read_morph_sequence


def test_horse_morph_sequence_reads_as_moving_frames(dev_assets):
    doc = GltfDocument.from_bytes((dev_assets / "meshseq_horse.glb").read_bytes())
    seq = read_morph_sequence(doc, fps=25.0, max_frames=5)
    assert seq.frames.shape == (5, 796, 3) and seq.fps == 25.0
    assert seq.faces.max() < 796 and len(seq.faces) > 100
    step = np.linalg.norm(np.diff(seq.frames, axis=0), axis=2).max(axis=1)
    assert np.all(step > 0)  # every frame moves
    size = np.ptp(seq.frames[0], axis=0).max()
    assert np.all(step < 0.2 * size)  # and by a plausible amount at 25 fps
