"""A tiny but complete wheel for any tags, so a zip's manifest can be installed by Blender in seconds."""
import base64
import hashlib
import os
import zipfile


def write_probe_wheel(folder: str, python_tag: str, abi_tag: str, platform_tag: str, name: str = "lapig_probe") -> str:
    """name-1.0-<python>-<abi>-<platform>.whl holding one module whose `TAG` says which wheel it came from."""
    files = {f"{name}/__init__.py": f'TAG = "{python_tag}-{abi_tag}"\n',
             f"{name}-1.0.dist-info/METADATA": f"Metadata-Version: 2.1\nName: {name}\nVersion: 1.0\n",
             f"{name}-1.0.dist-info/WHEEL": (f"Wheel-Version: 1.0\nGenerator: lapig-tests\nRoot-Is-Purelib: false\n"
                                             f"Tag: {python_tag}-{abi_tag}-{platform_tag}\n")}
    record = f"{name}-1.0.dist-info/RECORD"
    lines = []
    for path, text in files.items():
        digest = base64.urlsafe_b64encode(hashlib.sha256(text.encode()).digest()).rstrip(b"=").decode()
        lines.append(f"{path},sha256={digest},{len(text.encode())}")
    files[record] = "\n".join(lines + [f"{record},,"]) + "\n"
    path = os.path.join(folder, f"{name}-1.0-{python_tag}-{abi_tag}-{platform_tag}.whl")
    with zipfile.ZipFile(path, "w") as z:
        for member, text in files.items():
            z.writestr(member, text)
    return path
