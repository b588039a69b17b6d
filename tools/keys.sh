#!/usr/bin/env bash
# ./cairn keys DIR --robots r1,r2 [--commander ID=ROBOTS]... [--observer ID]... [--days N]
#
# Creates the DDS Security material (OMG DDS Security 1.1, Fast DDS built-in plugins) for one fleet with openssl:
#   DIR/ca.pem, DIR/ca.key        the fleet's certificate authority (identity and permissions CA). Keep ca.key
#                                 off the robots: whoever holds it can make any identity and any permission.
#   DIR/governance.xml, .p7s      the domain rule for domains 0-232: no unauthenticated participant joins;
#                                 discovery, liveliness and data encrypted (AES-GCM), RTPS messages signed
#                                 (GMAC); read and write access control on every topic. Signed by the CA.
#   DIR/ID/cert.pem, key.pem      one identity per robot, commander and observer (ECDSA P-256, CN=ID, O=Cairn).
#   DIR/ID/permissions.xml, .p7s  what ID may publish and read, signed by the CA:
#                                   robot R      publishes its state, maps, paths, answers and its yield
#                                                requests to peers, and reads everything (its commands come
#                                                on topics of its own, <command topic>/R, e.g.
#                                                cairn/mode_request/R, cairn/yield_request/R);
#                                   commander B  announces itself, probes links, asks for maps, reads
#                                                everything, publishes the command topics of the robots it was
#                                                given only (ROBOTS: r1+r2, or * for every robot), and may stop
#                                                any robot (an e-stop);
#                                   observer O   announces itself, probes links, asks for maps, reads everything:
#                                                no command.
#   DIR/ID/robots                 (commanders and observers) the robots ID may command, one per line ("*": all).
# A process started with --secure DIR loads DIR/ca.pem, DIR/governance.p7s and DIR/<its id>/.
# Ids: 1-64 characters of A-Z a-z 0-9 _ - (as the CLIs take them). DIR must not hold a fleet already.
set -euo pipefail

die() { printf 'cairn keys: %s\n' "$*" >&2; exit 2; }
usage() { sed -n '2,2p' "$0" | sed 's/^# //' >&2; exit 2; }

check_id() {  # field value
  [[ "$2" =~ ^[A-Za-z0-9_-]{1,64}$ ]] || die "$1 '$2' must be 1-64 characters of A-Z a-z 0-9 _ -"
}

[ $# -ge 1 ] || usage
DIR="$1"
shift
[[ "$DIR" != -* ]] || die "the first argument is the output folder, not '$DIR'"
ROBOTS=""
COMMANDERS=()
OBSERVERS=()
DAYS=3650
while [ $# -gt 0 ]; do
  case "$1" in
    --robots) ROBOTS="${2:?--robots needs a value, e.g. r1,r2}"; shift 2 ;;
    --commander) COMMANDERS+=("${2:?--commander needs ID=ROBOTS, e.g. opA=r1+r2 or opA=*}"); shift 2 ;;
    --observer) OBSERVERS+=("${2:?--observer needs an id}"); shift 2 ;;
    --days) DAYS="${2:?--days needs a value}"; shift 2 ;;
    -h|--help) sed -n '2,25p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown option '$1' (options: --robots, --commander, --observer, --days)" ;;
  esac
done
[[ "$DAYS" =~ ^[0-9]+$ ]] && [ "$DAYS" -ge 1 ] && [ "$DAYS" -le 36500 ] || die "--days '$DAYS' must be an integer in [1, 36500]"
[ -n "$ROBOTS" ] || die "--robots is required (the robot ids, comma separated)"
command -v openssl >/dev/null || die "openssl is not installed (apt-get install openssl)"

declare -A SEEN=()
IFS=',' read -r -a ROBOT_IDS <<<"$ROBOTS"
for r in "${ROBOT_IDS[@]}"; do
  check_id "robot id" "$r"
  [ -z "${SEEN[$r]:-}" ] || die "id '$r' is given twice"
  SEEN[$r]=robot
done
declare -A COMMANDS=()
for spec in "${COMMANDERS[@]}"; do
  [[ "$spec" == *=* ]] || die "--commander '$spec' must be ID=ROBOTS (r1+r2, or * for every robot)"
  id="${spec%%=*}"
  robots="${spec#*=}"
  check_id "commander id" "$id"
  [ -z "${SEEN[$id]:-}" ] || die "id '$id' is given twice"
  SEEN[$id]=commander
  [ -n "$robots" ] || die "--commander '$spec' names no robot"
  if [ "$robots" != "*" ]; then
    IFS='+' read -r -a list <<<"$robots"
    for r in "${list[@]}"; do
      [ "${SEEN[$r]:-}" = robot ] || die "--commander '$spec': '$r' is not one of --robots ($ROBOTS)"
    done
  fi
  COMMANDS[$id]="$robots"
done
for id in "${OBSERVERS[@]}"; do
  check_id "observer id" "$id"
  [ -z "${SEEN[$id]:-}" ] || die "id '$id' is given twice"
  SEEN[$id]=observer
  COMMANDS[$id]=""
done
if [ -e "$DIR/ca.pem" ]; then die "'$DIR' already holds a fleet's keys (ca.pem): choose another folder"; fi
mkdir -p "$DIR" || die "cannot create '$DIR'"

OPENSSL_LOG="$DIR/.openssl.log"
ossl() { openssl "$@" >>"$OPENSSL_LOG" 2>&1 || die "openssl $1 failed (see $OPENSSL_LOG)"; }

umask 077
ossl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -sha256 -days "$DAYS" \
  -keyout "$DIR/ca.key" -out "$DIR/ca.pem" -subj "/O=Cairn/CN=Cairn fleet CA"
chmod 644 "$DIR/ca.pem"

# Topics by who publishes them (robot_agent/src/communication/agent_dds.cpp, basestation/src/fleet_client.cpp).
ROBOT_TOPICS=(cairn/agent_info cairn/robot_state cairn/robot_pose cairn/bt_state cairn/global_path cairn/local_plan
              cairn/staircase cairn/camera cairn/map_update cairn/command_response cairn/path_response
              cairn/link_probe_reply cairn/explore_claim cairn/peer_state cairn/health cairn/yield_request)
# cairn/yield_request is the robots' own: they ask one another to get out of the way. An operator asks on the
# robot's command topic cairn/yield_request/R, so only R's commanders may.
BASE_TOPICS=(cairn/base_info cairn/link_probe cairn/map_sync_request)
COMMAND_TOPICS=(cairn/control_request cairn/mode_request cairn/waypoint_goal cairn/explore_request
                cairn/home_request cairn/stop_request cairn/teleop cairn/path_request cairn/restart_request
                cairn/convoy_request cairn/yield_request)

topics() { for t in "$@"; do printf '            <topic>%s</topic>\n' "$t"; done; }
# command_topics ROBOT...: every command topic of each robot (core::CommandTopicFor: "<topic>/<robot>"; * for all).
command_topics() { for r in "$@"; do for t in "${COMMAND_TOPICS[@]}"; do echo "$t/$r"; done; done; }

cat >"$DIR/governance.xml" <<'EOF'
<?xml version="1.0" encoding="UTF-8"?>
<!-- Cairn fleet governance (./cairn keys): who may join, and how traffic is protected. -->
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>232</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
EOF
ossl smime -sign -text -in "$DIR/governance.xml" -out "$DIR/governance.p7s" -signer "$DIR/ca.pem" -inkey "$DIR/ca.key"

NOT_BEFORE="$(date -u -d '-1 day' +%Y-%m-%dT%H:%M:%S)"
NOT_AFTER="$(date -u -d "+$DAYS days" +%Y-%m-%dT%H:%M:%S)"

# identity ID: key, certificate request, certificate signed by the CA; prints the certificate's subject.
identity() {
  local id="$1" d="$DIR/$1"
  mkdir -p "$d"
  ossl req -new -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes -sha256 \
    -keyout "$d/key.pem" -out "$d/cert.csr" -subj "/O=Cairn/CN=$id"
  ossl x509 -req -in "$d/cert.csr" -CA "$DIR/ca.pem" -CAkey "$DIR/ca.key" -CAcreateserial -sha256 \
    -days "$DAYS" -out "$d/cert.pem"
  rm -f "$d/cert.csr"
  chmod 644 "$d/cert.pem"
}

# permissions ID RULES_XML: the grant of ID (its certificate's subject, RFC 2253) with RULES_XML, signed.
permissions() {
  local id="$1" rules="$2" d="$DIR/$1" subject
  subject="$(openssl x509 -in "$d/cert.pem" -noout -subject -nameopt RFC2253 | sed 's/^subject=//')"
  cat >"$d/permissions.xml" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<!-- Permissions of $id (./cairn keys). -->
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$id">
      <subject_name>$subject</subject_name>
      <validity><not_before>$NOT_BEFORE</not_before><not_after>$NOT_AFTER</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>232</max></id_range></domains>
$rules
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
EOF
  ossl smime -sign -text -in "$d/permissions.xml" -out "$d/permissions.p7s" -signer "$DIR/ca.pem" \
    -inkey "$DIR/ca.key"
}

read_all() {
  printf '        <subscribe>\n          <topics>\n%s\n          </topics>\n        </subscribe>\n' "$(topics '*')"
}

for r in "${ROBOT_IDS[@]}"; do
  identity "$r"
  rules="        <publish>
          <topics>
$(topics "${ROBOT_TOPICS[@]}")
          </topics>
        </publish>
$(read_all)"
  permissions "$r" "$rules"
done

for id in "${!COMMANDS[@]}"; do
  identity "$id"
  rules="        <publish>
          <topics>
$(topics "${BASE_TOPICS[@]}")
          </topics>
        </publish>
$(read_all)"
  robots="${COMMANDS[$id]}"
  : >"$DIR/$id/robots"
  if [ -n "$robots" ]; then
    if [ "$robots" = "*" ]; then
      given=("*")
    else
      IFS='+' read -r -a given <<<"$robots"
    fi
    for r in "${given[@]}"; do echo "$r" >>"$DIR/$id/robots"; done
    # Its robots' command topics, and any robot's stop (an e-stop).
    mapfile -t allowed < <(command_topics "${given[@]}")
    rules="$rules
        <publish>
          <topics>
$(topics "${allowed[@]}" 'cairn/stop_request/*')
          </topics>
        </publish>"
  fi
  chmod 644 "$DIR/$id/robots"
  permissions "$id" "$rules"
done
rm -f "$DIR/ca.srl" "$OPENSSL_LOG"
printf 'cairn keys: %s: CA, governance, %d robot(s), %d commander(s), %d observer(s); keep %s/ca.key offline\n' \
  "$DIR" "${#ROBOT_IDS[@]}" "${#COMMANDERS[@]}" "${#OBSERVERS[@]}" "$DIR" >&2
