"""The compiled kernels (the Rust extension ``blisk_cam_kernels``, built from ``kernels/`` at
the repository root) behind numpy-shaped functions: :mod:`.backend` says which backend runs;
the numpy code beside each caller is the reference and the fallback."""
