"""MkDocs hook: the example data files of ``examples/`` travel with the site.

The format pages (docs/csv-format.md, docs/magnetic-format.md) link to ``../examples/NAME.csv``, a
path that works when the Markdown is read in the repository. MkDocs only resolves links to files
inside ``docs/``, so this hook adds every file of ``examples/`` to the site as ``examples/NAME``
and, in the pages at the top of ``docs/``, rewrites the link target ``../examples/`` to
``examples/``. The Markdown files stay as they are; a link to a missing example still fails the
strict build.
"""

import re
from pathlib import Path

from mkdocs.structure.files import File

_LINK = re.compile(r"\]\(\.\./examples/")


def _examples_dir(config) -> Path:
    return Path(config["config_file_path"]).resolve().parent / "examples"


def on_files(files, config):
    folder = _examples_dir(config)
    if folder.is_dir():
        for path in sorted(folder.iterdir()):
            if path.is_file() and not path.name.startswith("."):
                files.append(File.generated(config, f"examples/{path.name}", abs_src_path=str(path)))
    return files


def on_page_markdown(markdown, page, config, files):
    if "/" not in page.file.src_uri:          # a page at the top of docs/
        markdown = _LINK.sub("](examples/", markdown)
    return markdown
