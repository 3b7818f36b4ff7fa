"""The engine: compose a scene's pure step function, its state and its error bits."""
