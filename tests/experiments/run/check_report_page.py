#!/usr/bin/python3
"""Checks a sweep folder's index.html (experiments/run/report_page.h) with the standard library.

Usage: check_report_page.py OUT_DIR

Exit 0 when the page is what it promises, else 1 with one line per fault:
- it parses (html.parser) and loads nothing from elsewhere: no <script>, no <link>, no <iframe>,
  no absolute or scheme-qualified URL, no path that leaves OUT_DIR;
- every href and src names an existing file in OUT_DIR (URLs are percent-decoded first);
- every <img> is a valid PNG: the 8-byte signature, then an IHDR chunk of length 13 whose CRC
  matches, with a width and height above 0;
- every PNG under OUT_DIR/plots and OUT_DIR/images, and contact_sheet.png, is shown by an <img>;
- every row of OUT_DIR/summary.csv has its run_id in a table cell, and trace.csv, summary.csv
  and sweep.json are linked.
"""
import csv
import html.parser
import os
import struct
import sys
import urllib.parse
import zlib


class Page(html.parser.HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.urls = []  # (tag, attribute, value)
        self.images = []
        self.cells = []  # text of every <td>
        self.forbidden = []
        self._cell = None

    def handle_starttag(self, tag, attrs):
        if tag in ("script", "link", "iframe", "object", "embed"):
            self.forbidden.append(tag)
        for name, value in attrs:
            if name in ("href", "src"):
                self.urls.append((tag, name, value or ""))
                if tag == "img" and name == "src":
                    self.images.append(value or "")
        if tag == "td":
            self._cell = ""

    def handle_endtag(self, tag):
        if tag == "td" and self._cell is not None:
            self.cells.append(self._cell)
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data


def png_fault(path):
    """None if `path` starts like a valid PNG, else what is wrong."""
    with open(path, "rb") as f:
        head = f.read(33)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        return "no PNG signature"
    if len(head) < 33:
        return "too short for an IHDR chunk"
    length, kind = struct.unpack(">I4s", head[8:16])
    if kind != b"IHDR" or length != 13:
        return "the first chunk is not a 13-byte IHDR"
    width, height = struct.unpack(">II", head[16:24])
    (crc,) = struct.unpack(">I", head[29:33])
    if zlib.crc32(head[12:29]) != crc:
        return "IHDR CRC mismatch"
    if width == 0 or height == 0:
        return "zero width or height"
    return None


def local_file(out_dir, url):
    """The file a relative URL names inside out_dir, or (None, reason)."""
    parts = urllib.parse.urlsplit(url)
    if parts.scheme or parts.netloc or url.startswith("/"):
        return None, "not a relative link"
    if not parts.path:
        return None, "empty path"
    relative = urllib.parse.unquote(parts.path)
    root = os.path.realpath(out_dir)
    path = os.path.realpath(os.path.join(root, relative))
    if os.path.commonpath([root, path]) != root:
        return None, "leaves the folder"
    if not os.path.isfile(path):
        return None, "no such file"
    return path, None


def main():
    out_dir = sys.argv[1]
    faults = []
    page = Page()
    with open(os.path.join(out_dir, "index.html"), encoding="utf-8") as f:
        page.feed(f.read())
    page.close()
    for tag in page.forbidden:
        faults.append(f"<{tag}> loads or runs something besides the page")

    linked = set()
    for tag, attribute, url in page.urls:
        path, reason = local_file(out_dir, url)
        if reason:
            faults.append(f"<{tag} {attribute}=\"{url}\">: {reason}")
        else:
            linked.add(os.path.relpath(path, os.path.realpath(out_dir)))
    shown = set()
    for url in page.images:
        path, reason = local_file(out_dir, url)
        if path:
            shown.add(os.path.relpath(path, os.path.realpath(out_dir)))
            fault = png_fault(path)
            if fault:
                faults.append(f"<img src=\"{url}\">: {fault}")

    expected = [os.path.join(folder, name) for folder in ("plots", "images")
                if os.path.isdir(os.path.join(out_dir, folder))
                for name in sorted(os.listdir(os.path.join(out_dir, folder)))
                if name.endswith(".png")]
    if os.path.isfile(os.path.join(out_dir, "contact_sheet.png")):
        expected.append("contact_sheet.png")
    faults += [f"{name} is not shown" for name in expected if name not in shown]
    faults += [f"{name} is not linked" for name in ("trace.csv", "summary.csv", "sweep.json")
               if name not in linked]

    with open(os.path.join(out_dir, "summary.csv"), newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        faults.append("summary.csv has no rows")
    cells = set(page.cells)
    faults += [f"run {row['run_id']} is not in the table" for row in rows
               if row["run_id"] not in cells]

    for fault in faults:
        print(f"{out_dir}/index.html: {fault}")
    if not faults:
        print(f"{out_dir}/index.html: {len(page.urls)} links, {len(page.images)} PNGs, "
              f"{len(rows)} runs: ok")
    return 1 if faults else 0


if __name__ == "__main__":
    sys.exit(main())
