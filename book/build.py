"""Build the compendium's book, ``make book``: a static site of the executed notebooks (Jupyter Book 2).

    python book/build.py [--executed DIR] [--output DIR]

1. **The site theme** (MyST's book theme, v1.1.2, vendored source in ``book/theme/`` with a pinned
   ``package-lock.json``) is built once into ``build/book-theme/``: ``npm ci`` from the npm registry,
   then Tailwind and Remix. It is rebuilt only when ``book/theme/`` changes. MyST would otherwise
   download a prebuilt theme from the internet at every fresh build; this one needs the npm registry
   the first time and nothing afterwards, and the pages it makes load nothing from the internet
   (KaTeX's stylesheet and fonts are served by the site).
2. **The pages**, prepared in ``build/book-src/``: the landing page from ``README.md``, one page per
   executed notebook of ``make figures`` (``build/executed/``; nothing is re-executed), the
   reproduction report ``figures/REPRODUCTION.md`` and the benchmarks ``figures/benchmarks.md``.
   The theme shows no live widgets, so each ipywidgets view in an executed notebook is replaced by
   its static state: a line naming the controls' initial values and the output the view drew then.
3. **The site**: ``jupyter-book build --html`` (offline), moved to ``build/book/``. Serve it with
   ``python book/serve.py`` (the pages use absolute paths, so ``file://`` does not work, and a server
   that redirects ``/page`` to ``/page/``, like ``python -m http.server``, makes them reload forever).

Every failure is one line naming what is missing and what to run.
"""

import argparse
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BOOK = ROOT / "book"
THEME_SOURCE = BOOK / "theme"
BUILD = ROOT / "build"
THEME = BUILD / "book-theme"
SOURCE = BUILD / "book-src"
EXECUTED = BUILD / "executed"
SITE = BUILD / "book"
NOTEBOOKS = ROOT / "notebooks"
FIGURES = ROOT / "figures"

WIDGET_VIEW = "application/vnd.jupyter.widget-view+json"
WIDGET_STATE = "application/vnd.jupyter.widget-state+json"
NODE_MAJOR = 18
THEME_RECIPE = "2"   # bump when build_theme's steps change, so that built themes are rebuilt
# pages of the book, by the repository path that links point to
PAGES = {"README.md": "index.md", "figures/REPRODUCTION.md": "reproduction.md",
         "figures/benchmarks.md": "benchmarks.md"}
_LINK = re.compile(r"(!?\[[^\]]*\])\(([^)\s]+)\)")


class BookError(RuntimeError):
    """The book cannot be built; the message says why and what to run."""


def say(text):
    print(f"==> {text}", flush=True)


def run(command, cwd, what, env=None, timeout=1800):
    """Run ``command``; on failure raise :class:`BookError` with ``what`` and the output's tail."""
    started = time.time()
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-25:])
        raise BookError(f"{what} failed (exit {done.returncode}, `{' '.join(map(str, command))}` in {cwd}):\n{tail}")
    return time.time() - started


# ---------------------------------------------------------------------------------------------- theme

def theme_fingerprint(source=THEME_SOURCE):
    """SHA-256 over the theme's source files (names and contents): the built theme is rebuilt when it changes."""
    digest = hashlib.sha256(THEME_RECIPE.encode() + b"\0")
    for path in sorted(p for p in source.rglob("*") if p.is_file()):
        digest.update(path.relative_to(source).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def check_node():
    node = shutil.which("node")
    if node is None:
        raise BookError(f"`make book` needs Node.js >= {NODE_MAJOR} (`node` is not on PATH): "
                        "install it, e.g. `apt-get install nodejs npm`")
    version = subprocess.run([node, "--version"], capture_output=True, text=True).stdout.strip()
    major = int(re.match(r"v(\d+)", version).group(1)) if re.match(r"v(\d+)", version) else 0
    if major < NODE_MAJOR:
        raise BookError(f"`make book` needs Node.js >= {NODE_MAJOR}, found {version or 'an unknown version'}")
    if shutil.which("npm") is None:
        raise BookError("`make book` needs npm beside node (to install the site theme's pinned packages)")


def build_theme(source=THEME_SOURCE, target=THEME):
    """Build the site theme into ``target`` unless it was built from the same source already."""
    stamp = target / ".built-from"
    fingerprint = theme_fingerprint(source)
    if stamp.is_file() and stamp.read_text().strip() == fingerprint and (target / "build" / "index.js").is_file():
        say(f"site theme: up to date in {_shown(target)}")
        return
    check_node()
    say(f"site theme: building into {_shown(target)} (npm ci from the npm registry, then Tailwind "
        "and Remix; a few minutes, once)")
    if target.exists():
        shutil.rmtree(target)
    shutil.copytree(source, target)
    seconds = run(["npm", "ci", "--ignore-scripts", "--no-audit", "--no-fund"], target,
                  "installing the site theme's pinned npm packages")
    say(f"    npm ci: {seconds:.0f} s")
    # The same patch upstream applies: esbuild cannot inline these two @imports of a widget stylesheet
    for css in (target / "node_modules").glob("**/@jupyter-widgets/controls/css/widgets-base.css"):
        text = css.read_text()
        for name in ("lumino.css", "nouislider.css"):
            text = text.replace(f"@import './{name}';", f"/* @import './{name}'; */")
        css.write_text(text)
    # Outputs that need Jupyter's renderers (HTML tables) get a renderer without MathJax: thebe's default
    # loads MathJax 2 from a CDN on every page; without it they show LaTeX in such outputs as typed
    passive = target / "node_modules" / "@myst-theme" / "jupyter" / "dist" / "passive.js"
    text = passive.read_text()
    if "core.makeRenderMimeRegistry()" not in text:
        raise BookError(f"{passive}: no `core.makeRenderMimeRegistry()` to patch (a different @myst-theme/jupyter?)")
    passive.write_text(text.replace("core.makeRenderMimeRegistry()",
                                    "core.makeRenderMimeRegistry({ mathjaxUrl: '', mathjaxConfig: '' })"))
    bin_ = target / "node_modules" / ".bin"
    seconds = run([str(bin_ / "tailwindcss"), "-m", "-i", "./styles/app.css", "-o", "app/styles/app.css"],
                  target, "building the theme's stylesheet (tailwindcss)")
    seconds += run([str(bin_ / "remix"), "build"], target, "building the theme (remix build)",
                   env={**os.environ, "NODE_ENV": "production"})
    say(f"    tailwind + remix: {seconds:.0f} s")
    katex = target / "node_modules" / "katex" / "dist"
    shutil.copy2(katex / "katex.min.css", _mkdir(target / "public" / "build" / "katex") / "katex.min.css")
    shutil.copytree(katex / "fonts", target / "public" / "build" / "katex" / "fonts", dirs_exist_ok=True)
    # thebe-core's scripts, which the theme's pages import on load (upstream's copy-thebe-assets; no maps)
    thebe = target / "node_modules" / "thebe-core" / "dist" / "lib"
    for asset in [*thebe.glob("*.js"), thebe / "thebe-core.css"]:
        shutil.copy2(asset, target / "public" / asset.name)
    stamp.write_text(fingerprint + "\n")


def _mkdir(path):
    path.mkdir(parents=True, exist_ok=True)
    return path


# ---------------------------------------------------------------------------------------------- pages

def rewrite_links(text, page, known):
    """Point the relative links of the page at repository path ``page`` to the book's pages.

    ``known`` maps repository paths to book paths (e.g. ``"figures/REPRODUCTION.md" ->
    "reproduction.md"``). Links to files that are not in the book lose their link and keep their
    text; web links and in-page anchors are left alone.
    """
    here = Path(page).parent

    def replace(match):
        label, target = match.groups()
        if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            return match.group(0)
        path, _, anchor = target.partition("#")
        repo_path = os.path.normpath(here / path).replace(os.sep, "/")
        if repo_path in known:
            new = os.path.relpath(known[repo_path], Path(known.get(page, page)).parent).replace(os.sep, "/")
            return f"{label}({new}{'#' + anchor if anchor else ''})"
        if label.startswith("!"):
            return match.group(0)
        return label[1:-1]

    return _LINK.sub(replace, text)


def landing_page(readme):
    """The README as the book's landing page: HTML comments dropped, links pointed at the book."""
    text = re.sub(r"<!--.*?-->\n?", "", readme, flags=re.S)
    title, _, body = text.partition("\n")
    intro = ("\n:::{note} How to read this book\nThis is the rendered book of the compendium, built by "
             "`make book` from the notebooks as `make figures` executed them. Each chapter page is a "
             "notebook with its figures, equations and results; its Explore section shows the controls' "
             "initial view (move them in JupyterLab: `make lab`). The [reproduction report](reproduction.md) "
             "sets every checkable claim of the thesis beside our value.\n:::\n")
    return title + "\n" + intro + body


def widget_states(nb):
    """``{model_id: state}`` stored in the executed notebook's metadata (nbclient's saved widget state)."""
    widgets = nb.get("metadata", {}).get("widgets", {}).get(WIDGET_STATE, {})
    return {key: value.get("state", {}) for key, value in widgets.get("state", {}).items()}


_NOT_CONTROLS = ("LabelModel", "HTMLModel", "HTMLMathModel", "ImageModel", "ProgressStyleModel")


def _children(state):
    return [c[len("IPY_MODEL_"):] for c in state.get("children", []) if isinstance(c, str) and c.startswith("IPY_MODEL_")]


def _shown_value(state):
    value = state.get("value")
    if state.get("_model_name") in ("DropdownModel", "ToggleButtonsModel", "RadioButtonsModel", "SelectModel"):
        labels, index = state.get("_options_labels", []), state.get("index")
        if isinstance(index, int) and 0 <= index < len(labels):
            return labels[index]
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (list, tuple)):
        return "-".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
    return str(value)


def static_widget_outputs(model_id, states):
    """The static state of the widget ``model_id``: one text line naming its controls and their values,
    then the outputs its Output widgets captured, in the order they appear. Empty if the notebook
    holds no state for it."""
    controls, outputs, seen = [], [], set()

    def walk(key):
        if key in seen or key not in states:
            return
        seen.add(key)
        state = states[key]
        if state.get("_model_name") == "OutputModel":
            outputs.extend(state.get("outputs", []))
        elif ("value" in state or "index" in state) and state.get("_model_name") not in _NOT_CONTROLS:
            name = state.get("description") or state.get("_model_name", "control").replace("Model", "")
            controls.append(f"{name} = {_shown_value(state)}")
        for child in _children(state):
            walk(child)

    walk(model_id)
    if not seen:
        return []
    lines = ["Controls (their initial values; move them in JupyterLab, `make lab`):" if controls
             else "A widget (live in JupyterLab, `make lab`)"]
    for control in controls:  # a few per line, never split inside one
        if len(lines) > 1 and len(lines[-1]) + len(control) + 2 <= 88:
            lines[-1] += "; " + control
        else:
            lines.append("  " + control)
    return [{"output_type": "stream", "name": "stdout", "text": "\n".join(lines) + "\n"}] + outputs


def static_widgets(nb):
    """Replace every ipywidgets view in ``nb`` (an nbformat dict) by its static state, in place; returns
    the number of views replaced. A view whose state the notebook does not hold keeps its text form."""
    states, replaced = widget_states(nb), 0
    for cell in nb.get("cells", []):
        new = []
        for output in cell.get("outputs", []):
            view = output.get("data", {}).get(WIDGET_VIEW)
            static = static_widget_outputs(view.get("model_id"), states) if view else []
            if static:
                new.extend(static)
                replaced += 1
            elif view:
                new.append({**output, "data": {k: v for k, v in output["data"].items() if k != WIDGET_VIEW}})
            else:
                new.append(output)
        if "outputs" in cell:
            cell["outputs"] = new
    nb.get("metadata", {}).pop("widgets", None)
    return replaced


def _sources(nb):
    return [(c["cell_type"], "".join(c["source"]) if isinstance(c["source"], list) else c["source"])
            for c in nb["cells"] if "injected-parameters" not in c.get("metadata", {}).get("tags", [])]


def executed_notebooks(executed=EXECUTED, notebooks=NOTEBOOKS):
    """The executed copies of every notebook in ``notebooks/``, checked to be present, successful, and
    executed from the notebook as it is now (same cells)."""
    found = []
    for notebook in sorted(notebooks.glob("[0-9][0-9]_*.ipynb")):
        copy = executed / notebook.name
        if not copy.is_file():
            raise BookError(f"no executed copy of {_shown(notebook)} in {_shown(executed)}: "
                            "run `make figures` first (the book shows the notebooks as it executed them)")
        nb, current = json.loads(copy.read_text()), json.loads(notebook.read_text())
        if _sources(nb) != _sources(current):
            raise BookError(f"{_shown(copy)} is older than {_shown(notebook)} (its cells changed since "
                            "it was executed): run `make figures` again")
        errors = [o for c in nb["cells"] for o in c.get("outputs", []) if o.get("output_type") == "error"]
        if errors:
            raise BookError(f"{_shown(copy)} holds an error ({errors[0].get('ename')}: {errors[0].get('evalue')}): "
                            "it did not run through; run `make figures` again")
        found.append((notebook, nb))
    if not found:
        raise BookError(f"no notebooks in {notebooks}")
    return found


def _shown(path):
    path = Path(path).resolve()
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def prepare_sources(executed=EXECUTED, target=SOURCE):
    """Write the book's pages into ``target``: myst.yml, the landing page, the notebooks (widgets made
    static, links pointed at the book), the report, the benchmarks and the figures they show."""
    notebooks = executed_notebooks(executed)
    for required in ("figures/REPRODUCTION.md", "figures/benchmarks.md"):
        if not (ROOT / required).is_file():
            raise BookError(f"no {required}: run `make figures` (the report) or `make bench` (the benchmarks)")
    if target.exists():
        shutil.rmtree(target)
    (target / "notebooks").mkdir(parents=True)
    known = dict(PAGES) | {f"notebooks/{nb.name}": f"notebooks/{nb.name}" for nb, _ in notebooks}
    known |= {f"figures/{p.name}": f"figures/{p.name}" for p in FIGURES.glob("*") if p.suffix in (".png", ".gif", ".svg")}
    shutil.copy2(BOOK / "myst.yml", target / "myst.yml")
    shutil.copy2(favicon(), target / "favicon.ico")
    (target / "index.md").write_text(rewrite_links(landing_page((ROOT / "README.md").read_text()), "README.md", known))
    for page, name in (("figures/REPRODUCTION.md", "reproduction.md"), ("figures/benchmarks.md", "benchmarks.md")):
        (target / name).write_text(rewrite_links((ROOT / page).read_text(), page, known))
    views = 0
    for notebook, nb in notebooks:
        views += static_widgets(nb)
        page = f"notebooks/{notebook.name}"
        for cell in nb["cells"]:
            if cell["cell_type"] == "markdown":
                text = "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]
                cell["source"] = rewrite_links(text, page, known)
        (target / page).write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n")
    figures = _mkdir(target / "figures")
    for image in FIGURES.glob("*"):
        if image.suffix in (".png", ".gif", ".svg"):
            shutil.copy2(image, figures / image.name)
    say(f"pages: {len(notebooks)} notebooks ({views} widget views made static), the README, the report and the "
        f"benchmarks in {_shown(target)}")
    return notebooks


def favicon():
    """A favicon from the installed Jupyter server (MyST's theme would fetch one from the internet)."""
    import jupyter_server

    return Path(jupyter_server.__file__).parent / "static" / "favicon.ico"


# ---------------------------------------------------------------------------------------------- site

def jupyter_book():
    found = Path(sys.executable).parent / "jupyter-book"
    if not found.is_file():
        raise BookError(f"no jupyter-book beside {sys.executable}: run `make env` (it is in environment.lock)")
    return found


def build_site(source=SOURCE, output=SITE):
    """``jupyter-book build --html`` in ``source``; the static site is moved to ``output``."""
    check_node()
    env = {k: v for k, v in os.environ.items() if k not in ("BASE_URL", "READTHEDOCS_CANONICAL_URL")}
    seconds = run([str(jupyter_book()), "build", "--html", "--ci"], source, "building the site (jupyter-book build --html)",
                  env=env | {"JB_ALLOW_NODEENV": "0"})
    html = source / "_build" / "html"
    if not (html / "index.html").is_file():
        raise BookError(f"jupyter-book wrote no {_shown(html / 'index.html')}")
    if output.exists():
        shutil.rmtree(output)
    shutil.move(str(html), str(output))
    say(f"site: {_shown(output)} in {seconds:.0f} s (serve it: .venv/bin/python book/serve.py, then open http://127.0.0.1:8000)")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--executed", type=Path, default=EXECUTED,
                        help="folder of executed notebooks (default: build/executed, written by `make figures`)")
    parser.add_argument("--output", type=Path, default=SITE, help="where the site goes (default: build/book)")
    args = parser.parse_args(argv)
    try:
        build_theme()
        prepare_sources(args.executed.resolve())
        build_site(output=args.output.resolve())
    except BookError as err:
        sys.exit(f"make book: {err}")
    except subprocess.TimeoutExpired as err:
        sys.exit(f"make book: `{' '.join(map(str, err.cmd))}` did not finish within {err.timeout:.0f} s")


if __name__ == "__main__":
    main()
