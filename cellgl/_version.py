"""The cellgl version (one place: pyproject.toml reads it, snippet headers print it).

MAJOR.MINOR.PATCH, semver-ish while the major is 0: a release that renames or removes a public
name (``cellgl.*``, the command line's commands and options, the recipe JSON's keys, a snippet's
entry points) or changes an output's bits raises MINOR; one that only adds or fixes raises PATCH.
From 1.0 on, breaking changes raise MAJOR. CHANGELOG.md says what each release changed.
"""
__version__ = "0.2.0"
