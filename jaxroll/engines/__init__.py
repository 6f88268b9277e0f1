"""The physics engines, in the order of the pipeline:

* :mod:`~jaxroll.engines.special`: Bessel and Struve functions in JAX;
* :mod:`~jaxroll.engines.layer`: the layer and its transfer function ``T(q)``;
* :mod:`~jaxroll.engines.stack`: bonded ply stacks and their compliance;
* :mod:`~jaxroll.engines.contact_size`: the contact half-width or radius of each method;
* :mod:`~jaxroll.engines.pressure`: the assumed pressure profiles of the direct method;
* :mod:`~jaxroll.engines.direct`: the direct series (the paper's Eq. 27 / 28);
* :mod:`~jaxroll.engines.aperiodic`: the infinite-layer (aperiodic) compliance kernels;
* :mod:`~jaxroll.engines.cylinder`: the full 2D (line contact) model;
* :mod:`~jaxroll.engines.sphere3d`: the full 3D (point contact) model;
* :mod:`~jaxroll.engines.slices`: the sphere as cylinder slices (PD, PP, SP).

Users normally reach them through the method objects (:class:`jaxroll.Full`, ...) and
:func:`jaxroll.rolling_resistance`; the modules are importable for their lower-level functions.
"""

from . import special, layer, stack, contact_size, pressure, direct, aperiodic, cylinder, sphere3d, slices  # noqa: E402,F401
