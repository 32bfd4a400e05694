"""The ground floor: what every Sheer package shares, and nothing else.

- :mod:`core.errors`: :class:`~core.errors.SheerError`, the base of every error whose message is meant
  for the user (the CLI and the studio show it without a traceback), and
  :class:`~core.errors.AssetNotFoundError`.
- :mod:`core.atomicio`: atomic file writes (fsync of the file and of its folder, an optional ``.bak``).
- :mod:`core.files`: :func:`~core.files.read_bounded`, reading a user's file whole, bounded in size, with
  one set of refusals (missing, a folder, a FIFO or device, too large).
- :mod:`core.cache`: the cache folder (``$SHEER_CACHE_DIR``, else ``$XDG_CACHE_HOME/sheer``) and its one
  policy: checked entries (:func:`~core.cache.save_arrays` / :func:`~core.cache.load_arrays`, in the
  format of :mod:`core.cache_entry`), a size cap with least-recently-used eviction, private caches.
- :mod:`core.migrations`: :class:`~core.migrations.Migrations`, upgrading a parsed JSON document
  through registered per-version steps (on a copy; a failing step is the format's own error).
- :mod:`core.lazy`: :func:`~core.lazy.install_lazy`, lazy public names for a package's ``__init__``.
- :mod:`core.camera`: the one camera — its conventions (OpenGL's eye and clip spaces, OpenCV's camera
  space, pixel centres) and the conversion between them, ``look_at``, ``perspective``, ``orthographic``,
  the pinhole camera (:class:`~core.camera.Pinhole`) and its clip matrices.
- :mod:`core.assets`: where Sheer's files are (:func:`~core.assets.resource_path` in the ``resources``
  data package, :func:`~core.assets.find_asset` on the sample assets' search path) and the assets'
  credits.

May import: the standard library, numpy and xxhash (the cache entries' checksum) only (``resources`` is
read as files, never imported). Every other Sheer package may import it.
"""
