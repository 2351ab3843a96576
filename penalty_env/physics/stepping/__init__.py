"""Stepping: integrators and the paths that step a batch of worlds.

===================  ============================================================================
module               what it holds
===================  ============================================================================
``forces``           a world's contact passes and accelerations (the scalar paths')
``integrators``      one step per method (explicit / symplectic Euler, velocity Verlet, RK4,
                     linearised backward Euler)
``spin_steps``       the integrators' side of rotation
``common``           status codes, scratch buffers, control inputs to forces
``scalar``           the scalar path: each world serially, any integrator
``lanes``            the SIMD-lanes path: a block of worlds per vector instruction
``event_scan``       event location's geometry and scan; ``events``: its driver
``large``            the large-world path's kernels: Verlet lists, slabs in parallel
``neighbour_lists``  its Python side: a list per world, grown on demand
``runner``           the one place that owns threads and chooses how a batch is stepped
===================  ============================================================================
"""
