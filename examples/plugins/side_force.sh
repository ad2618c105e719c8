#!/bin/sh
# An aeroid plug-in with nothing but a POSIX shell and awk: the side-force
# derivative CY_beta by least squares, the other side-force terms held at
# their values in problem.json (Klein & Morelli, "Aircraft System
# Identification", ch. 5):
#
#   z = m·g0·ny/(q̄·S) − Σ_fixed C_term·x_term = CY_beta·β + e,
#   CY_beta = Σ β·z / Σ β²,  σ² = Σ e²/(N − 1),  σ(CY_beta) = √(σ²/Σ β²),
#
# with p̂ = p·b/(2V), r̂ = r·b/(2V). It reads problem.json (pretty-printed
# by aeroid: one key per line, an array of numbers on one line) and the
# record folder record-0/, and
# refuses any other free parameter. Usage (by aeroid): side_force.sh WORK
set -eu
work=$1
problem=$work/problem.json

refuse() {
    printf '{"kind": "unsuitable-model", "method": "%s", "model": "%s", "reason": "%s"}\n' \
        "$method" "$model" "$1" > "$work/refusal.json"
    exit 0
}

value() { # the first number after "KEY": in problem.json
    awk -v key="\"$1\":" '$1 == key && $2 ~ /^-?[0-9]/ { v = $2; sub(/,$/, "", v); print v; exit }' "$problem"
}
method=$(awk '$1 == "\"method\":" { v = $2; gsub(/[",]/, "", v); print v; exit }' "$problem")
model=$(awk '$1 == "\"name\":" && seen { v = $2; gsub(/[",]/, "", v); print v; exit } /"structure":/ { seen = 1 }' "$problem")
mass=$(value mass)
area=$(value wing_area)
span=$(value span)
[ "$(awk '$1 == "\"rate_normalization\":" { v = $2; gsub(/[",]/, "", v); print v; exit }' "$problem")" = 2V ] \
    || refuse "this example knows the 2V rate normalisation only"

# name start free, one line per parameter
parameters=$(awk '
    $1 == "\"name\":" { name = $2; gsub(/[",]/, "", name) }
    $1 == "\"start\":" { start = $2; sub(/,$/, "", start) }
    $1 == "\"free\":" { free = $2; sub(/,$/, "", free); if (name != "") print name, start, free; name = "" }
    /"integrate":/ { exit }' "$problem")
echo "$parameters" | awk '$3 == "true" && $1 != "CY_beta" { bad = bad " " $1 } END { if (bad != "") exit 1 }' \
    || refuse "this example estimates CY_beta alone; hold the other parameters (fixed = true)"
echo "$parameters" | awk '$1 == "CY_beta" && $3 == "true" { found = 1 } END { exit !found }' \
    || refuse "CY_beta is not free"

csv=$(ls "$work"/record-0/*.csv | head -n 1)
echo "$parameters" | awk -v mass="$mass" -v area="$area" -v span="$span" -v csv="$csv" '
    BEGIN { g0 = 9.80665 }
    # The fixed side-force terms.
    FILENAME == "-" {
        if ($1 ~ /^CY_/ && $3 == "false") { term = substr($1, 4); fixed[term] = $2 }
        next
    }
    FNR == 1 {
        for (i = 1; i <= NF; i++) { split($i, part, " "); column[part[1]] = i }
        next
    }
    {
        v = $column["airspeed"]; q = $column["dynamic_pressure"]; beta = $column["beta"]
        x["0"] = 1; x["beta"] = beta
        x["p"] = $column["p"] * span / (2 * v); x["r"] = $column["r"] * span / (2 * v)
        x["da"] = $column["aileron"]; x["dr"] = $column["rudder"]
        z = mass * g0 * $column["ny"] / (q * area)
        for (term in fixed) z -= fixed[term] * x[term]
        n++; sxx += beta * beta; sxz += beta * z; szz += z * z
    }
    END {
        theta = sxz / sxx
        variance = (szz - 2 * theta * sxz + theta * theta * sxx) / (n - 1)
        printf "{\"format\": \"aeroid-plugin-estimate-1\", \"status\": \"converged\", "
        printf "\"parameters\": [{\"name\": \"CY_beta\", \"value\": %.17g, \"standard_error\": %.17g}], ", theta, sqrt(variance / sxx)
        printf "\"iterations\": 1, \"notes\": [\"%d samples, shell and awk\"]}\n", n
    }' - FS=, "$csv" > "$work/estimate.json"
