"""The built-in geometries, one module each (``geometry.name``): a pydantic model of its parameters,
``describe(params)`` and ``build(gmsh, scale, params)``; geometry/__init__.py collects them."""
