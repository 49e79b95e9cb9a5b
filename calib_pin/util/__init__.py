"""Small utilities every layer uses: argument checks, units, progress, files written whole."""
