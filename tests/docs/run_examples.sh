#!/bin/bash
# Runs every `standcal` example of README.md and docs/*.md as written, in one working
# directory, in reading order (README first), with the built programs first on PATH.
#
# An example is a line inside a fenced block that starts, at its first column, with
# `standcal ` (or `$ standcal `),
# joined with its `\` continuations, without its trailing `# comment`. It is left out, and
# the reason printed, when it is a synopsis (holds [ ] | … or an UPPER_CASE placeholder
# such as RUN_ID or REC.csv) or needs a bench (a stand, a CAN bus, a running daemon, a
# PostgreSQL server, the installed /etc and /var/lib). Exit status 0, 3, 4 and 5 are
# answers (README "Exit status"); 1 (runtime error) or 2 (usage error) fails the test.
#
# What the examples take for granted is made first: limits.json is the limits example of
# docs/certificate.md, old-bench/AU-0017.csv a recording of unit AU-0017.
#
# usage: run_examples.sh SOURCE_DIR BIN_DIR...
set -u
source_dir=$(realpath "$1")
shift
for bin in "$@"; do PATH="$(realpath "$bin"):$PATH"; done
export PATH
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1

# The fenced-block example lines of a markdown file, continuations joined.
examples_of() {
  awk '
    /^```/ { fenced = !fenced; next }
    !fenced { next }
    {
      line = $0
      sub(/^\$ /, "", line)
      if (joined != "") { joined = joined " " line } else if (line ~ /^standcal /) { joined = line } else next
      if (joined ~ /\\$/) { sub(/[ ]*\\$/, "", joined); next }
      print joined
      joined = ""
    }' "$1"
}

# Why an example cannot run here as written, or nothing.
reason_to_leave_out() {
  local example=$1 word
  case $example in
    *"["* | *"|"* | *"…"* | *"..."*) echo "synopsis"; return ;;
    *" --url "* | *" --can "* | *" stand "* | *" unit "*) echo "needs a stand or a CAN bus"; return ;;
    *postgresql://*) echo "needs a PostgreSQL server"; return ;;
    *" --tcp "* | "standcal run "* | "standcal runs"* | "standcal status"* | "standcal doctor"* | \
      "standcal estop"*) echo "needs a running standcald"; return ;;
    *" /etc/"* | *" /var/lib/"*) echo "needs the installed /etc and /var/lib"; return ;;
  esac
  local words
  read -ra words <<< "$example"  # split on blanks only: no glob expansion of the words
  for word in "${words[@]}"; do
    if [[ $word =~ ^[A-Z][A-Z0-9_]*(\.[a-z]+)?$ ]]; then
      echo "synopsis (placeholder $word)"
      return
    fi
  done
}

# What the examples take for granted.
awk '/^```json/ { block = ""; inside = 1; next }
     inside && /^```/ { inside = 0; if (block ~ /standcal-limits\/1/) { printf "%s", block; exit } ; next }
     inside { block = block $0 "\n" }' "$source_dir/docs/certificate.md" > limits.json
mkdir -p old-bench
if ! standcal simulate --program paper9 --seed 17 --unit-serial AU-0017 --dwell-s 20 \
    -o old-bench/AU-0017.csv > /dev/null; then
  echo "could not make old-bench/AU-0017.csv"
  exit 1
fi

ran=0 left_out=0 failed=0
for doc in "$source_dir/README.md" "$source_dir"/docs/*.md; do
  name=${doc#"$source_dir"/}
  while IFS= read -r example; do
    example=$(sed -E 's/[[:space:]]+#[[:space:]].*$//; s/[[:space:]]+$//' <<< "$example")
    reason=$(reason_to_leave_out "$example")
    if [[ -n $reason ]]; then
      echo "left out ($reason): $name: $example"
      left_out=$((left_out + 1))
      continue
    fi
    ran=$((ran + 1))
    # A subshell without the example list on stdin: an example that reads stdin, or names
    # an unset variable, cannot eat the rest of the list or stop the script.
    (eval "$example") < /dev/null > out.txt 2>&1
    status=$?
    case $status in
      0 | 3 | 4 | 5) echo "ran (exit $status): $name: $example" ;;
      *)
        echo "FAILED (exit $status): $name: $example"
        sed 's/^/    /' out.txt | head -20
        failed=$((failed + 1))
        ;;
    esac
  done < <(examples_of "$doc")
done
echo "$ran examples ran, $failed failed, $left_out left out"
[[ $failed -eq 0 && $ran -gt 0 ]]
