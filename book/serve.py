"""Serve the built book (``build/book/``) on this machine::

    python book/serve.py [--port 8000] [--bind 127.0.0.1] [DIR]

Python's ``http.server`` answers ``/chapter`` with a redirect to ``/chapter/``; the book's pages then
see another address than the one they were rendered for and reload forever (Remix's hydration check).
This server answers ``/chapter`` with ``/chapter/index.html`` directly, as static hosts for MyST sites do.
"""

import argparse
import functools
import os
import sys
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

SITE = Path(__file__).resolve().parents[1] / "build" / "book"


class BookHandler(SimpleHTTPRequestHandler):
    """Static files; a folder's ``index.html`` without the redirect to a trailing slash."""

    def _no_redirect(self):
        path, query = self.path.partition("?")[0], self.path.partition("?")[2]
        local = self.translate_path(path)
        if not path.endswith("/") and os.path.isdir(local) and os.path.isfile(os.path.join(local, "index.html")):
            self.path = path + "/index.html" + (f"?{query}" if query else "")

    def do_GET(self):
        self._no_redirect()
        super().do_GET()

    def do_HEAD(self):
        self._no_redirect()
        super().do_HEAD()

    def log_message(self, format, *args):  # noqa: A002 (the base class's name)
        if os.environ.get("BOOK_SERVER_QUIET") != "1":
            super().log_message(format, *args)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directory", nargs="?", type=Path, default=SITE)
    parser.add_argument("--port", type=int, default=8000)
    parser.add_argument("--bind", default="127.0.0.1")
    args = parser.parse_args(argv)
    if not (args.directory / "index.html").is_file():
        sys.exit(f"serve: no {args.directory / 'index.html'}: run `make book` first")
    handler = functools.partial(BookHandler, directory=str(args.directory))
    with ThreadingHTTPServer((args.bind, args.port), handler) as server:
        print(f"serving {args.directory} at http://{args.bind}:{server.server_address[1]}/ (Ctrl-C stops)", flush=True)
        try:
            server.serve_forever()
        except KeyboardInterrupt:
            pass


if __name__ == "__main__":
    main()
