# SPDX-License-Identifier: GPL-3.0-or-later
"""A Hugging Face-style hub over plain HTTP (urllib): the repository's file listing and ranged file reads.

The endpoints are the Hub's own, as huggingface_hub uses them:
- GET {endpoint}/api/models/{repo}/tree/{revision}?recursive=true: a JSON list of entries
  {"type": "file", "path", "size", "oid": git blob sha1, "lfs": {"oid": sha256, "size", "pointerSize"}}, paged
  with a Link: <next>; rel="next" header;
- GET {endpoint}/{repo}/resolve/{revision}/{path}: the file (a redirect to a CDN for large ones), with Range.
Errors: 401 (no or a refused token; the Hub also says 401 for a repository that does not exist), 403 with
X-Error-Code GatedRepo (the licence is not accepted on the model's page), 404 (RepoNotFound, EntryNotFound).
The endpoint is the caller's (a setting), else HF_ENDPOINT, else https://huggingface.co. A token goes as
Authorization: Bearer, and only to the endpoint's own host: a redirect to a CDN carries a signed address instead.
"""
from __future__ import annotations

import json
import os
import re
import urllib.error
import urllib.parse
import urllib.request
from dataclasses import dataclass

from .catalogue import ModelError

DEFAULT_ENDPOINT = "https://huggingface.co"
TIMEOUT_S = 30.0
_MAX_REDIRECTS = 5
_NEXT = re.compile(r'<([^>]+)>;\s*rel="next"')


def endpoint(setting: str = "", env=None) -> str:
    env = os.environ if env is None else env
    return (setting.strip() or env.get("HF_ENDPOINT", "").strip() or DEFAULT_ENDPOINT).rstrip("/")


@dataclass(frozen=True)
class RemoteFile:
    path: str
    size: int
    sha256: str | None  # the LFS files' (the weights)
    git_oid: str  # git's blob sha1 (the small files are checked by it)
    local: str = ""  # where it goes in the model's folder, where not at `path` (an fp16 copy under the default name)

    @property
    def local_path(self) -> str:
        return self.local or self.path


class _KeepMethodRedirects(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args, **kwargs):  # redirects are followed by hand (the token stays home)
        return None


def _tls_context():
    """The system's certificates, or certifi's where it is installed (Blender bundles it; a Python on macOS may
    have no system store it can read)."""
    import ssl

    try:
        import certifi
        return ssl.create_default_context(cafile=certifi.where())
    except ImportError:
        return ssl.create_default_context()


_OPENER = urllib.request.build_opener(_KeepMethodRedirects, urllib.request.HTTPSHandler(context=_tls_context()))


class Hub:
    def __init__(self, base: str = "", token: str = "", timeout_s: float = TIMEOUT_S):
        self.base = endpoint(base)
        self.token = (token or "").strip()
        self.timeout_s = timeout_s

    # ------------------------------------------------------------------------------------------- requests
    def open(self, url: str, headers: dict | None = None, repo_id: str = ""):
        """The response of GET url (redirects followed, the token only for the endpoint's host); ModelError
        worded for the user on an HTTP error or an unreachable hub."""
        home = urllib.parse.urlsplit(self.base).netloc
        for _ in range(_MAX_REDIRECTS + 1):
            request = urllib.request.Request(url, headers=dict(headers or {}))
            request.add_header("User-Agent", "lapig-blender")
            if self.token and urllib.parse.urlsplit(url).netloc == home:
                request.add_header("Authorization", f"Bearer {self.token}")
            try:
                return _OPENER.open(request, timeout=self.timeout_s)
            except urllib.error.HTTPError as err:
                if err.code in (301, 302, 303, 307, 308) and err.headers.get("Location"):
                    url = urllib.parse.urljoin(url, err.headers["Location"])
                    err.close()
                    continue
                raise self._refusal(err, repo_id, url) from None
            except (urllib.error.URLError, TimeoutError, ConnectionError) as err:
                reason = getattr(err, "reason", err)
                raise ModelError(f"cannot reach {self.base} ({reason}): check the network, or set the model "
                                 f"hub's address in the add-on's preferences") from None
        raise ModelError(f"{self.base} redirected more than {_MAX_REDIRECTS} times: the hub's address is wrong")

    def _refusal(self, err, repo_id: str, url: str) -> ModelError:
        code, error_code = err.code, err.headers.get("X-Error-Code", "")
        bad_token = "Invalid credentials" in err.headers.get("X-Error-Message", "")
        what = f"'{repo_id}'" if repo_id else url
        err.close()
        if code == 403 and error_code == "GatedRepo" or code == 403 and not self.token:
            return ModelError(f"{what} is gated: accept its licence on https://huggingface.co/{repo_id} with your "
                              f"account, then paste a token of that account in the preferences' Hub token")
        if code == 401 and self.token and error_code == "RepoNotFound" and not bad_token:
            return ModelError(f"{self.base} has no model {what} that this token may read (HTTP 401): check the "
                              f"name, and that the token's account has access to it")
        if code in (401, 403) and self.token:
            return ModelError(f"the hub refused the token for {what} (HTTP {code}): check the Hub token in the "
                              f"preferences (a read token of an account that accepted the model's licence)")
        if code == 401:
            return ModelError(f"{self.base} has no model {what} or it needs a token (HTTP 401): check the name, "
                              f"or paste a Hub token in the preferences")
        if code == 404:
            if error_code == "EntryNotFound":
                return ModelError(f"{what} lacks the file {url.rsplit('/', 1)[-1]} (HTTP 404)")
            return ModelError(f"{self.base} has no model {what} (HTTP 404): check its name")
        return ModelError(f"{self.base} answered HTTP {code} for {what}: try again later")

    # --------------------------------------------------------------------------------------------- the API
    def list_files(self, repo_id: str, revision: str = "main") -> list[RemoteFile]:
        """Every file of the repository at revision, with its size and hashes."""
        rev = urllib.parse.quote(revision, safe="")
        url = f"{self.base}/api/models/{repo_id}/tree/{rev}?recursive=true"
        files = []
        while url:
            with self.open(url, {"Accept": "application/json"}, repo_id) as response:
                try:
                    page = json.loads(response.read().decode("utf-8"))
                except (ValueError, UnicodeDecodeError):
                    raise ModelError(f"{self.base} did not answer with a file list for '{repo_id}': is it a "
                                     f"Hugging Face hub?") from None
                link = response.headers.get("Link", "")
            if not isinstance(page, list):
                raise ModelError(f"{self.base} did not answer with a file list for '{repo_id}'")
            for entry in page:
                if isinstance(entry, dict) and entry.get("type") == "file":
                    lfs = entry.get("lfs") or {}
                    files.append(RemoteFile(entry["path"], int(entry.get("size", 0)), lfs.get("oid") or None,
                                            str(entry.get("oid", ""))))
            match = _NEXT.search(link)
            url = urllib.parse.urljoin(url, match.group(1)) if match else ""
        if not files:
            raise ModelError(f"'{repo_id}' has no files at revision '{revision}'")
        return files

    def file_url(self, repo_id: str, path: str, revision: str = "main") -> str:
        return (f"{self.base}/{repo_id}/resolve/{urllib.parse.quote(revision, safe='')}/"
                f"{urllib.parse.quote(path)}")

    def open_file(self, repo_id: str, path: str, start: int = 0, revision: str = "main"):
        """The file's bytes from `start` on; the response's status is 206 where the hub honoured the range
        (200: from the first byte again)."""
        headers = {"Range": f"bytes={start}-"} if start > 0 else {}
        headers["Accept-Encoding"] = "identity"  # the bytes as stored: the hashes are of those
        return self.open(self.file_url(repo_id, path, revision), headers, repo_id)
