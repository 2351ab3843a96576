"""The contact law and where it is evaluated.

=============  ================================================================================
module         what it holds
=============  ================================================================================
``law``        the law, once: normal force, regularised friction, the history spring, levers
``pair``       a ball pair (scalar): force, overlap, the implicit solver's products
``terrain``    a ball and every terrain shape (scalar)
``spin``       spinning balls: slip, tangential force, torque, rolling resistance
``lanes``      the law over a block of worlds, one per SIMD lane
``listed``     the law over a block of neighbour-list pairs
=============  ================================================================================
"""
