# Sourced by the scripts that plot: sets $python to a python3 that has Debian's matplotlib, numpy
# and pandas (scripts/install-deps.sh installs them for /usr/bin/python3; a python3 earlier on
# PATH, e.g. from pyenv, may lack them).
python=""
for candidate in python3 /usr/bin/python3; do
  if command -v "$candidate" >/dev/null 2>&1 &&
     "$candidate" -c 'import matplotlib, numpy, pandas' >/dev/null 2>&1; then
    python="$candidate"
    break
  fi
done
if [ -z "$python" ]; then
  echo "no python3 with matplotlib, numpy and pandas; run scripts/install-deps.sh" >&2
  exit 1
fi
