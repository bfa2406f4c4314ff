"""penumbra's PEP 517 build backend: `pip install .` builds the package with CMake and installs the
module, its type stubs and the `penumbra` command into the environment.

In-tree (pyproject.toml: backend-path = ["python/build_backend"]) and standard library only, so that it
builds offline with Debian's tools: `pip install --no-build-isolation .` (CMake, Ninja, a C++ compiler
and the -dev packages of scripts/install-deps.sh must be installed; pip downloads nothing).

The wheel holds penumbra/ (__init__.py, widget.py and widget.js, the compiled _penumbra module,
__init__.pyi, py.typed) and the `penumbra` executable as a script (penumbra-VERSION.data/scripts/), which pip puts in the environment's
bin/. The CMake build lives in build/wheel-<interpreter> (config setting "build-dir" to change it),
so that a second install only rebuilds what changed. Config setting "jobs" sets the build's -j;
"prebuilt" (with "build-dir") packs a build tree as it is, without building.
"""
import base64
import hashlib
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import tempfile
import zipfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def _version():
    with open(os.path.join(ROOT, "CMakeLists.txt"), encoding="utf-8") as f:
        m = re.search(r"project\(penumbra VERSION ([0-9.]+)", f.read())
    if not m:
        raise RuntimeError("penumbra_build: no 'project(penumbra VERSION x.y.z)' in CMakeLists.txt")
    return m.group(1)


def _tag():
    """The wheel's tag for this interpreter: cpXY-cpXY-<platform> (the module is built for it alone)."""
    impl = f"cp{sys.version_info.major}{sys.version_info.minor}"
    platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
    return f"{impl}-{impl}-{platform}"


def _metadata(version):
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        readme = f.read()
    return (f"Metadata-Version: 2.1\nName: penumbra\nVersion: {version}\n"
            "Summary: Direct volume rendering and molecule rendering with shadows and ambient occlusion, "
            "each technique measured against the exact reference\n"
            "Requires-Python: >=3.9\nRequires-Dist: numpy\nProvides-Extra: widget\n"
            "Requires-Dist: ipywidgets>=6; extra == \"widget\"\nLicense: see the repository\n"
            "Description-Content-Type: text/markdown\n\n" + readme)


def _wheel_file():
    return f"Wheel-Version: 1.0\nGenerator: penumbra_build\nRoot-Is-Purelib: false\nTag: {_tag()}\n"


def _run(command, where):
    print("penumbra_build:", " ".join(command), flush=True)
    try:
        subprocess.run(command, cwd=where, check=True)
    except FileNotFoundError as e:
        raise RuntimeError(f"penumbra_build: {command[0]} is not installed ({e}); scripts/install-deps.sh installs "
                           f"what the build needs") from None


def _build(config_settings):
    settings = config_settings or {}
    build_dir = settings.get("build-dir") or os.path.join(ROOT, "build", f"wheel-cp{sys.version_info.major}{sys.version_info.minor}")
    if settings.get("prebuilt"):  # pack what the build tree holds, building nothing (the tests, beside running binaries)
        if not os.path.exists(os.path.join(build_dir, "penumbra")):
            raise RuntimeError(f"penumbra_build: prebuilt: {build_dir} holds no built penumbra (build it first)")
        return build_dir
    jobs = str(settings.get("jobs") or os.cpu_count() or 2)
    configure = ["cmake", "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_UNITY_BUILD=ON", f"-DPython3_EXECUTABLE={sys.executable}",
                 "-DPENUMBRA_BUILD_TESTS=OFF", "-DPENUMBRA_BUILD_BENCH=OFF"]
    if shutil.which("ninja"):
        configure += ["-G", "Ninja"]
    if shutil.which("ccache"):
        configure += ["-DCMAKE_CXX_COMPILER_LAUNCHER=ccache", "-DCMAKE_C_COMPILER_LAUNCHER=ccache"]
    if not os.path.exists(os.path.join(build_dir, "CMakeCache.txt")) or settings.get("reconfigure"):
        _run(configure, ROOT)
    _run(["cmake", "--build", build_dir, "--target", "penumbra", "penumbra_python", "-j", jobs], ROOT)
    return build_dir


def _record_line(path, data):
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{path},sha256={digest},{len(data)}"


def build_wheel(wheel_directory, config_settings=None, metadata_directory=None):
    version = _version()
    build_dir = _build(config_settings)
    package = os.path.join(build_dir, "python", "penumbra")
    files = {}  # path in the wheel -> (bytes, executable)
    for name in sorted(os.listdir(package)):
        if name == "_build_info.py" or name.endswith((".py", ".pyi", ".so", ".js")) or name == "py.typed":
            with open(os.path.join(package, name), "rb") as f:
                files[f"penumbra/{name}"] = (f.read(), False)
    if not any(p.endswith(".so") for p in files):
        raise RuntimeError(f"penumbra_build: the compiled module is missing from {package}")
    with open(os.path.join(build_dir, "penumbra"), "rb") as f:
        files[f"penumbra-{version}.data/scripts/penumbra"] = (f.read(), True)
    info = f"penumbra-{version}.dist-info"
    files[f"{info}/METADATA"] = (_metadata(version).encode(), False)
    files[f"{info}/WHEEL"] = (_wheel_file().encode(), False)
    record = [_record_line(p, data) for p, (data, _) in files.items()] + [f"{info}/RECORD,,"]
    files[f"{info}/RECORD"] = ("\n".join(record).encode() + b"\n", False)
    name = f"penumbra-{version}-{_tag()}.whl"
    with zipfile.ZipFile(os.path.join(wheel_directory, name), "w", zipfile.ZIP_DEFLATED) as z:
        for path, (data, executable) in files.items():
            entry = zipfile.ZipInfo(path, date_time=(2026, 1, 1, 0, 0, 0))
            entry.external_attr = (0o100755 if executable else 0o100644) << 16  # a regular file (pip checks)
            entry.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(entry, data)
    return name


def prepare_metadata_for_build_wheel(metadata_directory, config_settings=None):
    """The wheel's .dist-info without building: what pip reads before it builds."""
    version = _version()
    info = f"penumbra-{version}.dist-info"
    os.makedirs(os.path.join(metadata_directory, info), exist_ok=True)
    with open(os.path.join(metadata_directory, info, "METADATA"), "w", encoding="utf-8") as f:
        f.write(_metadata(version))
    with open(os.path.join(metadata_directory, info, "WHEEL"), "w", encoding="utf-8") as f:
        f.write(_wheel_file())
    return info


def build_sdist(sdist_directory, config_settings=None):
    """The tracked files of the checkout (git ls-files), as penumbra-VERSION.tar.gz."""
    version = _version()
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout.decode().split("\0")
    name = f"penumbra-{version}.tar.gz"
    with tarfile.open(os.path.join(sdist_directory, name), "w:gz") as t:
        for path in filter(None, listed):
            t.add(os.path.join(ROOT, path), arcname=f"penumbra-{version}/{path}", recursive=False)
        with tempfile.NamedTemporaryFile("w", delete=False) as f:
            f.write(_metadata(version))
        t.add(f.name, arcname=f"penumbra-{version}/PKG-INFO")
        os.unlink(f.name)
    return name


def get_requires_for_build_wheel(config_settings=None):
    return []  # CMake and the compilers come from Debian (scripts/install-deps.sh), not from PyPI


def get_requires_for_build_sdist(config_settings=None):
    return []
