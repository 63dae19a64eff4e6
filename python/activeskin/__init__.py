"""Active implicit skins (Desbrun & Cani 1997) on particle simulations.

A skin follows the particles frame by frame, through the same frame loop as the
``activeskin particles`` command: the same particles and parameters give the same
surfaces, byte for byte.

>>> import numpy as np, activeskin
>>> skin = activeskin.ParticleSkin(radius=0.02, fps=24)
>>> mesh = skin.advance(np.random.rand(5000, 3) * 0.4)
>>> mesh.vertices.shape[1], mesh.triangles.dtype
(3, dtype('uint32'))
"""

from ._activeskin import Mesh, ParticleSkin, __version__, read_particles

__all__ = ["Mesh", "ParticleSkin", "__version__", "read_particles"]
