// DDS plumbing shared by every Cairn process: participants created only from the shipped XML profiles,
// typed writers and readers over fastddsgen types, and a checked entity chain with clear errors.
#pragma once

#include <fastrtps/types/TypesBase.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <fastdds/dds/core/status/LivelinessChangedStatus.hpp>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <shared_mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cairn/core/link_options.h"

namespace cairn::core {

/// A DDS entity could not be created or configured. The message names the entity, profile and cause.
class DdsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Largest domain id Fast DDS 2.9.1 accepts (port 7400 + 250·d must fit in 16 bits); beyond it the library
/// calls exit(1), so every id is checked here first.
inline constexpr long kMaxDomainId = 232;

/// Shortest AUTOMATIC liveliness lease on a network link (lan, radio), in seconds: eight of the profiles' 250
/// ms assertions, so that a cut or a dead process lapses it, not a fade of a second (Participant::WriterQos).
inline constexpr double kNetworkLivelinessLeaseS = 2.0;

/// Checks a domain id given as text (CLI flag, config) and returns it.
/// @throws std::invalid_argument naming `field` and the value when it is not an integer in [0, 232].
int ParseDomainId(const std::string& text, const std::string& field = "--domain");

/// Default location of the shipped profiles file (config/dds_profiles.xml of the source tree), overridable
/// with the environment variable CAIRN_DDS_PROFILES.
std::string DefaultProfilesFile();

/// A flow controller the participant registers (docs/DESIGN.md: map and camera writers are flow-controlled so
/// that they never starve commands). Writers opt in by name (Writer's `flow_controller` argument).
struct FlowControllerOptions {
  std::string name;                ///< e.g. "cairn.map"; unique per participant
  double budget_bits_per_s = 0.0;  ///< bytes on the wire per second * 8, > 0
  int period_ms = 100;             ///< budget window, [1, 10000]
};

/// An IPv4 subnet in CIDR form (a named network of a link profile).
struct Ipv4Subnet {
  std::uint32_t network = 0;  ///< host byte order, host bits cleared
  int prefix_length = 32;     ///< [0, 32]
  std::string text;           ///< as given, e.g. "10.77.0.0/24"
  bool Contains(std::uint32_t address) const;
};

/// "A.B.C.D/N" into an Ipv4Subnet (host bits are cleared). @throws std::invalid_argument naming the text.
Ipv4Subnet ParseIpv4Subnet(const std::string& text);

/// What a participant may use besides loopback (127.0.0.0/8 is always in scope): the named subnets for
/// whitelisted interfaces and unicast locators, and multicast groups when `multicast` (sent only on the
/// whitelisted interfaces). Empty: loopback only.
struct NetworkScope {
  std::vector<Ipv4Subnet> subnets;
  bool multicast = false;
  /// True for a loopback address or one in a named subnet (host byte order).
  bool Contains(std::uint32_t address) const;
  /// E.g. "loopback (127.0.0.0/8) and 10.77.0.0/24, multicast on those".
  std::string Describe() const;
};

/// True when `qos` stays within `scope`: built-in transports off, UDPv4 user transports whose whitelists hold
/// only addresses in scope, and every locator list (metatraffic and default unicast, initial peers, discovery
/// servers) in scope, multicast lists empty unless the scope names multicast. Otherwise false, with `*why`
/// naming the list or whitelist and the address.
bool WithinNetworkScope(const eprosima::fastdds::dds::DomainParticipantQos& qos, const NetworkScope& scope,
                        std::string* why);

/// The local address a lan link binds to: the one interface with an IPv4 address in `link.subnet`, or the
/// IPv4 address of `link.interface_name` (both given: that interface's address must be in the subnet).
/// `*subnet` receives the named subnet (or the interface's own). @throws std::invalid_argument naming the
/// option, the value and the interfaces seen.
std::string ResolveLinkAddress(const LinkOptions& link, Ipv4Subnet* subnet);

/// "loopback" | "lan" check of `link` (names the field and value). @throws std::invalid_argument.
void CheckLinkOptions(const LinkOptions& link);

/// "A.B.C.D:PORT" (LinkOptions::discovery_server) into (address, port). @throws std::invalid_argument naming
/// the flag and the value.
std::pair<std::string, std::uint32_t> ParseDiscoveryServer(const std::string& text);

/// A UDPv4 locator: `address` (dotted quad), `port` (0: Fast DDS chooses).
eprosima::fastrtps::rtps::Locator_t Udpv4Locator(const std::string& address, std::uint32_t port);

/// The topic a basestation sends `robot_id` one kind of command on (`topic`: one of CommandTopics()). Without
/// DDS Security every robot shares `topic`. With it (`secure`), each robot has its own, "<topic>/<robot_id>"
/// (e.g. "cairn/mode_request/r1"), so that signed permissions can say who may command which robot: Fast DDS
/// 2.9's access control checks an endpoint's topic name against the permissions, but not its partitions.
std::string CommandTopicFor(const std::string& topic, const std::string& robot_id, bool secure);

/// The topics a basestation commands a robot on (control, mode, goal, explore, home, stop, teleop, path
/// queries, restart, convoy, yield); tools/keys.sh lists the same. Robots ask one another to yield on the
/// shared cairn/yield_request, which under DDS Security only robots may write.
const std::vector<std::string>& CommandTopics();

/// Whether the participant whose GUID prefix is `prefix` holds the certificate `./cairn keys` makes for `id`
/// (subject O=Cairn, CN=id). Under DDS Security the PKI-DH handshake refuses a participant unless the first
/// 47 bits of its GUID prefix are 1 followed by the first 47 bits of SHA-256 of its certificate's subject
/// (DER; DDS Security 1.1 section 9.3.2.5.2, Fast DDS PKIDH "Bad participant_key's 47bits"), and the fleet's
/// governance signs every RTPS message per pair of participants: so a sample's writer GUID names the
/// certificate it was sent under, and a message whose sender id (a base id, a robot id) is not that
/// certificate's was forged by another identity of the fleet. Meaningless without security (any prefix).
bool GuidPrefixHoldsIdentity(const eprosima::fastrtps::rtps::GuidPrefix_t& prefix, const std::string& id);

/// Whether a sample (`info`: its writer) came under the certificate of `claimed`, the sender id it carries:
/// GuidPrefixHoldsIdentity on the writer's GUID prefix under DDS Security (`security` enabled); always true
/// without it (no identity exists then).
bool SentUnder(const SecurityOptions& security, const eprosima::fastdds::dds::SampleInfo& info,
               const std::string& claimed);

/// The id in a certificate subject as Fast DDS's identity token carries it (X509_NAME_oneline, e.g.
/// "/O=Cairn/CN=op3"): the value of its last CN; "" when it has none.
std::string IdentityOfSubject(const std::string& subject);

/// How a participant is created.
struct ParticipantOptions {
  int domain_id = 0;                                   ///< DDS domain, [0, 232].
  std::string profiles_file = DefaultProfilesFile();   ///< Fast DDS XML profiles file.
  std::string participant_profile = "cairn.loopback";  ///< participant profile name in that file.
  std::string name = "cairn";                          ///< participant name seen by peers.
  /// The networks the participant may use (network safety, docs/DESIGN.md): loopback only by default; a
  /// profile that would listen on, announce or send to anything else is refused with the reason.
  NetworkScope network;
  /// The link (LinkOptions): `lan` rebuilds the profile's transport and locators on the named network and
  /// sets `network` to it.
  LinkOptions link;
  /// Flow controllers to register; names must be unique. @see FlowControllerOptions.
  std::vector<FlowControllerOptions> flow_controllers;
  /// DDS Security; off by default. When on, every file it names must be readable (DdsError naming it), and
  /// the participant neither discovers nor talks to anyone without a certificate from the same CA.
  SecurityOptions security;
  /// Called (on a Fast DDS thread) with the ParticipantIdOf a remote participant that left (a clean exit,
  /// `dropped` false) or was dropped (its lease expired: a crash or a lost link, `dropped` true). Sees every
  /// process, announced or not.
  std::function<void(const std::string& participant_id, bool dropped)> on_participant_gone;
  /// Re-create the participant after this process stalled long enough for peers to drop it (Participant's
  /// stall watchdog). Off only in tests that need a fixed participant.
  bool rebuild_after_stall = true;
  /// Called (on the watchdog's thread, after every endpoint is back) with the new ParticipantIdOf after a
  /// rebuild: what peers now see as this process.
  std::function<void(const std::string& participant_id)> on_rebuilt;
};

/// An entity of a Participant that Participant::Rebuild deletes and re-creates (Writer and Reader).
class ParticipantEndpoint {
 public:
  virtual ~ParticipantEndpoint() = default;

 protected:
  friend class Participant;
  /// Deletes the DDS entity (the participant is about to go); called with the rebuild lock held.
  virtual void DeleteEntity() = 0;
  /// Creates it again on the new participant; called with the rebuild lock held.
  virtual void CreateEntity() = 0;
  /// After every endpoint is back and the exclusive lock released: publish what waited for the rebuild;
  /// called with the entities lock held shared (do not take it again).
  virtual void AfterRebuild() {}
};

/// One DomainParticipant with one publisher and one subscriber, built from an XML profile.
///
/// The participant is never created with Fast DDS default transports: the profile must load, must exist,
/// and it must stay within ParticipantOptions::network (WithinNetworkScope; loopback only by default).
/// Destruction deletes every contained entity and the participant (no /dev/shm or port leftovers).
///
/// Stalls. A process stopped (SIGSTOP, swap, a debugger) for longer than the participant lease is dropped
/// by its peers, but on resuming it may read their queued announcements before its own lease check runs and
/// so keep them: the peers then never get its endpoints again (Fast DDS 2.9 does not re-send endpoint
/// discovery to a reader it counts as up to date; eProsima/Fast-DDS issues #155 and #457) and each side
/// stays deaf to the other until a restart. A watchdog thread therefore measures its own wake-ups on the
/// steady clock; a gap longer than stall_threshold_s() (the lease less one announcement period: long enough
/// that a peer may have dropped us) makes it Rebuild() the participant: every Writer and Reader is deleted,
/// the participant is created again from the same QoS (a new GUID, so every peer discovers it afresh) and
/// each endpoint is re-created. Writes during a rebuild wait in their writer and go out after it; a
/// transient-local writer re-publishes its last sample for the peers that now join it.
class Participant : private eprosima::fastdds::dds::DomainParticipantListener {
 public:
  /// @throws DdsError naming the profiles file, profile or entity that failed; std::invalid_argument for a
  ///         domain id out of range.
  explicit Participant(const ParticipantOptions& options);
  ~Participant() override;
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  eprosima::fastdds::dds::DomainParticipant* get() const { return participant_; }
  eprosima::fastdds::dds::Publisher* publisher() const { return publisher_; }
  eprosima::fastdds::dds::Subscriber* subscriber() const { return subscriber_; }
  const ParticipantOptions& options() const { return options_; }

  /// Registers `type` (once per type name) and returns the topic `topic_name`, creating it on first use.
  /// @throws DdsError when registration or creation fails.
  eprosima::fastdds::dds::Topic* GetTopic(const std::string& topic_name,
                                          const eprosima::fastdds::dds::TypeSupport& type);

  /// " (DDS Security: ...)" naming the permissions file when security is on, else "": appended to the error
  /// of an endpoint the access control may have refused.
  std::string SecurityHint() const;

  /// The registered flow controller's name as Fast DDS holds it, or nullptr if none has that name.
  const char* FlowControllerName(const std::string& name) const;
  /// The QoS of writer profile `profile` (e.g. "cairn.latched.writer") as this participant uses it; Writer
  /// and Reader create their endpoints with these.
  ///  - Network safety for endpoints: a profile whose unicast, remote or multicast locators leave
  ///    options().network is refused.
  ///  - On a network link (lan, radio) a finite AUTOMATIC liveliness lease shorter than
  ///    kNetworkLivelinessLeaseS is raised to it, on writers and readers alike (a reader's lease must not be
  ///    shorter than its writer's, or they never match). Liveliness is the robot's dead-man check on its
  ///    operator (manual and smart joystick stop when it lapses): on a radio, a fade of a second must not
  ///    throw the operator out of their mode (teleop going stale already stops the robot within 0.5 s).
  /// @throws DdsError naming the profile (not defined), or the locator list and the locator.
  eprosima::fastdds::dds::DataWriterQos WriterQos(const std::string& profile) const;
  /// The same for reader profile `profile` (e.g. "cairn.latched.reader").
  eprosima::fastdds::dds::DataReaderQos ReaderQos(const std::string& profile) const;

  /// Under DDS Security, the id of the certificate the remote participant `participant_id` (ParticipantIdOf)
  /// authenticated with, as its identity token names it and checked against its GUID prefix
  /// (GuidPrefixHoldsIdentity); "" when unknown (no security, not discovered yet, gone, or a token that does
  /// not match). Thread-safe.
  std::string CertifiedIdOf(const std::string& participant_id) const;

  /// This participant's identity (ParticipantIdOf its GUID): what peers see as the sender of its samples.
  /// Changes with every Rebuild().
  std::string participant_id() const;

  /// Deletes the DDS participant with every endpoint and creates them again (see the class comment);
  /// `why` is logged. Thread-safe; endpoints' writes meanwhile wait in their writer.
  /// @throws DdsError when the participant cannot be created again (the endpoints then stay deleted).
  void Rebuild(const std::string& why);
  /// Rebuilds done so far.
  int rebuilds() const { return rebuilds_.load(); }
  /// A watchdog wake-up later than this (seconds) counts as a stall that peers may have dropped us for: the
  /// participant lease less one lease announcement period; 0 when the watchdog is off (option, or an
  /// infinite lease).
  double stall_threshold_s() const { return stall_threshold_s_; }

 private:
  template <class>
  friend class Writer;
  template <class>
  friend class Reader;

  void on_participant_discovery(eprosima::fastdds::dds::DomainParticipant* participant,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override;
  // Creates participant_, publisher_ and subscriber_ from qos_; throws DdsError.
  void CreateEntities();
  // Deletes them (and any endpoint still on them).
  void DeleteEntities();
  void WatchForStalls();
  void Register(ParticipantEndpoint* endpoint);
  void Unregister(ParticipantEndpoint* endpoint);

  ParticipantOptions options_;
  eprosima::fastdds::dds::DomainParticipantQos qos_;
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  std::mutex mutex_;
  // Fast DDS keeps `const char*` names of flow controllers: the strings live here, as long as the
  // participant.
  std::deque<std::string> flow_controller_names_;
  // Locks. Rebuilds run one at a time (rebuild_mutex_, taken first). entities_mutex_ is held exclusively by
  // Rebuild while it deletes and creates, and shared by an endpoint while it uses its entity.
  // endpoints_mutex_ guards endpoints_: always taken after entities_mutex_ when both are held (the exclusive
  // lock in Rebuild, a shared one in Register and around AfterRebuild), never before it.
  std::mutex rebuild_mutex_;
  std::shared_mutex entities_mutex_;
  std::mutex endpoints_mutex_;
  std::set<ParticipantEndpoint*> endpoints_;
  mutable std::mutex certified_mutex_;                // guards certified_ids_ (taken on a DDS thread)
  std::map<std::string, std::string> certified_ids_;  // remote ParticipantIdOf -> its certificate's id
  mutable std::mutex id_mutex_;
  std::string participant_id_;
  std::atomic<int> rebuilds_{0};
  double stall_threshold_s_ = 0.0;
  std::mutex watchdog_mutex_;
  std::condition_variable watchdog_cv_;
  bool watchdog_stop_ = false;
  std::thread watchdog_;
};

/// True when a liveliness change means the writer `status.last_publication_handle` is gone: its liveliness
/// lapsed (not_alive +1), or it was unmatched while alive (alive -1, not_alive unchanged), which is how Fast
/// DDS 2.9 reports a participant whose lease expired. Seen in tests with five participants on one host:
/// the writer-liveliness path alone did not fire after a SIGKILL, the participant lease did.
inline bool IsLivelinessLoss(const eprosima::fastdds::dds::LivelinessChangedStatus& status) {
  return status.not_alive_count_change > 0 ||
         (status.alive_count_change < 0 && status.not_alive_count_change == 0);
}

/// Identity of the process behind a DDS entity: its participant's GUID prefix as 12 dotted hex bytes
/// ("01.0f.3a.7c.10.2b.00.00.01.00.00.00"), as Fast DDS tools print it. Two live processes never share
/// one; a restarted process gets a new one. `handle` is a writer's or reader's instance handle (for
/// example SampleInfo::publication_handle or LivelinessChangedStatus::last_publication_handle); "" when
/// the handle is unset.
std::string ParticipantIdOf(const eprosima::fastrtps::rtps::InstanceHandle_t& handle);
/// The same for a participant's own GUID (DomainParticipant::guid()).
std::string ParticipantIdOf(const eprosima::fastrtps::rtps::GUID_t& guid);
/// Identity of one writer (its whole GUID, 16 dotted hex bytes): what a retry from the same process shares
/// and a command from any other process does not. "" when the handle is unset.
std::string WriterIdOf(const eprosima::fastrtps::rtps::InstanceHandle_t& handle);

/// Polls `value` every 5 ms until it reaches `count`; false after `timeout`.
bool WaitForCount(const std::atomic<int>& value, int count, std::chrono::milliseconds timeout);

/// Typed writer for a fastddsgen type. `PubSubT` is the generated `XPubSubType`; `PubSubT::type` is X.
/// QoS comes from the XML profile "<qos_class>.writer" (e.g. "cairn.command.writer").
/// A fastddsgen type support whose getKey() runs one call at a time. Fast DDS shares one type support per
/// participant among every writer and reader of the type, and the generated getKey() fills a key buffer the
/// type support owns: two writers of a keyed type writing on different threads raced on it (ThreadSanitizer,
/// a latched re-publish after a rebuild beside an application write), which can give a sample another
/// instance's key.
template <class PubSubT>
class KeySafePubSubType : public PubSubT {
 public:
  bool getKey(void* data, eprosima::fastrtps::rtps::InstanceHandle_t* handle,
              bool force_md5 = false) override {
    std::lock_guard<std::mutex> lock(key_mutex_);
    return PubSubT::getKey(data, handle, force_md5);
  }

 private:
  std::mutex key_mutex_;
};

template <class PubSubT>
class Writer : private eprosima::fastdds::dds::DataWriterListener, private ParticipantEndpoint {
 public:
  using Msg = typename PubSubT::type;

  /// Samples a writer holds while its participant is rebuilt; the oldest goes first beyond this.
  static constexpr std::size_t kMaxHeldDuringRebuild = 256;

  /// `flow_controller`: name of a flow controller registered on the participant (ParticipantOptions), or
  /// "" for none. With one, the writer publishes asynchronously within that controller's budget.
  /// @throws DdsError when the profile or flow controller is missing or the writer cannot be created.
  Writer(Participant& participant, const std::string& topic_name, const std::string& qos_class,
         const std::string& flow_controller = "")
      : participant_(participant),
        topic_name_(topic_name),
        qos_class_(qos_class),
        flow_controller_(flow_controller) {
    std::shared_lock<std::shared_mutex> lock(participant_.entities_mutex_);
    CreateEntity();
    participant_.Register(this);
  }
  ~Writer() override {
    participant_.Unregister(this);
    std::shared_lock<std::shared_mutex> lock(participant_.entities_mutex_);
    DeleteEntity();
  }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  /// Publishes one sample; false when Fast DDS refuses it (history full of unacknowledged samples, etc.).
  /// A sample written counts into bytes_written() with its serialized size. During a Participant::Rebuild
  /// the sample is held (true) and published once the writer is back.
  bool Write(const Msg& msg) {
    std::shared_lock<std::shared_mutex> lock(participant_.entities_mutex_, std::try_to_lock);
    if (!lock.owns_lock()) {
      {
        std::lock_guard<std::mutex> held(held_mutex_);
        if (held_.size() >= kMaxHeldDuringRebuild) held_.erase(held_.begin());
        held_.push_back(msg);
      }
      // The rebuild may have finished (and flushed) between the failed lock and the push.
      if (lock.try_lock()) FlushHeld();
      return true;
    }
    FlushHeld();
    return WriteEntity(msg);
  }

  /// Waits until every matched reliable reader acknowledged what was written, or `timeout` passes; false on
  /// timeout or while the participant is being rebuilt.
  bool WaitForAcknowledgments(std::chrono::milliseconds timeout) {
    std::shared_lock<std::shared_mutex> lock(participant_.entities_mutex_, std::try_to_lock);
    if (!lock.owns_lock()) return false;
    const auto ms = timeout.count();
    return writer_->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(
               static_cast<int32_t>(ms / 1000), static_cast<uint32_t>((ms % 1000) * 1000000))) ==
           eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
  }

  /// Serialized bytes (CDR, encapsulation included; no RTPS headers, no resends) of the samples written so
  /// far.
  std::uint64_t bytes_written() const { return bytes_written_.load(std::memory_order_relaxed); }
  /// Samples written so far.
  std::uint64_t samples_written() const { return samples_written_.load(std::memory_order_relaxed); }

  /// Number of matched readers.
  int matched() const { return matched_.load(); }

  /// Waits until at least `count` readers matched; false on timeout.
  bool WaitForMatched(int count, std::chrono::milliseconds timeout) const {
    return WaitForCount(matched_, count, timeout);
  }

  /// True when a reader of the participant `participant_id` (ParticipantIdOf) is matched: that process can
  /// hear this writer (its endpoint discovery has completed with ours).
  bool MatchedWith(const std::string& participant_id) const {
    std::lock_guard<std::mutex> lock(matched_mutex_);
    return MatchedLocked(participant_id);
  }

  /// Waits until MatchedWith(participant_id) holds or `deadline` passes; returns whether it holds.
  bool WaitMatchedWith(const std::string& participant_id,
                       std::chrono::steady_clock::time_point deadline) const {
    std::unique_lock<std::mutex> lock(matched_mutex_);
    return matched_cv_.wait_until(lock, deadline, [&] { return MatchedLocked(participant_id); });
  }

  /// The current DDS writer (another after a Participant::Rebuild).
  eprosima::fastdds::dds::DataWriter* get() const { return writer_; }

 private:
  void CreateEntity() override {
    eprosima::fastdds::dds::DataWriterQos qos = participant_.WriterQos(qos_class_ + ".writer");
    auto* topic = participant_.GetTopic(
        topic_name_, eprosima::fastdds::dds::TypeSupport(new KeySafePubSubType<PubSubT>()));
    if (!flow_controller_.empty()) {
      const char* name = participant_.FlowControllerName(flow_controller_);
      if (name == nullptr) {
        throw DdsError("flow controller '" + flow_controller_ + "' is not registered on participant '" +
                       participant_.options().name + "'");
      }
      qos.publish_mode().kind = eprosima::fastdds::dds::ASYNCHRONOUS_PUBLISH_MODE;
      qos.publish_mode().flow_controller_name = name;
    }
    latched_ = qos.durability().kind != eprosima::fastdds::dds::VOLATILE_DURABILITY_QOS;
    writer_ = participant_.publisher()->create_datawriter(topic, qos, this);
    if (writer_ == nullptr) {
      throw DdsError("cannot create writer on topic '" + topic_name_ + "' with QoS profile '" + qos_class_ +
                     ".writer' from " + participant_.options().profiles_file + participant_.SecurityHint());
    }
  }
  void DeleteEntity() override {
    if (writer_ == nullptr) return;
    writer_->set_listener(nullptr);
    participant_.publisher()->delete_datawriter(writer_);
    writer_ = nullptr;
    std::lock_guard<std::mutex> lock(matched_mutex_);
    matched_readers_.clear();
    matched_.store(0);
    matched_cv_.notify_all();
  }
  void AfterRebuild() override {
    if (FlushHeld() > 0 || !latched_) return;
    // The new writer's history is empty: re-publish the last sample for the peers that join it now.
    std::optional<Msg> last;
    {
      std::lock_guard<std::mutex> held(held_mutex_);
      last = last_;
    }
    if (last) WriteEntity(*last);
  }

  // With the entities lock shared. Publishes the samples held during a rebuild; returns how many.
  std::size_t FlushHeld() {
    std::vector<Msg> held;  // no allocation while nothing is held: every Write() passes here
    {
      std::lock_guard<std::mutex> guard(held_mutex_);
      held.swap(held_);
    }
    for (const Msg& msg : held) WriteEntity(msg);
    return held.size();
  }
  // With the entities lock shared.
  bool WriteEntity(const Msg& msg) {
    if (writer_ == nullptr) return false;
    try {
      if (!writer_->write(const_cast<Msg*>(&msg))) return false;
    } catch (const std::exception&) {
      // Fast CDR throws out of write() when a sample or its key does not fit the type's buffers (a keyed
      // string longer than 255 bytes): refused like any other sample Fast DDS will not take.
      return false;
    }
    if (latched_) {
      std::lock_guard<std::mutex> held(held_mutex_);
      last_ = msg;
    }
    // CDR size plus the 4-byte encapsulation header, as the generated type's size provider computes it.
    bytes_written_.fetch_add(Msg::getCdrSerializedSize(msg) + 4u, std::memory_order_relaxed);
    samples_written_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }
  // With matched_mutex_ held.
  bool MatchedLocked(const std::string& participant_id) const {
    auto it = matched_readers_.find(participant_id);
    return it != matched_readers_.end() && it->second > 0;
  }
  // Everything under matched_mutex_, the notify too: the callback may run on another participant's thread
  // (one that re-creates its entities and matches them with this writer in process), and DeleteEntity() takes
  // the same lock before the destructor frees the condition variable (ThreadSanitizer: a notify after the
  // unlock raced with ~Writer's pthread_cond_destroy).
  void on_publication_matched(eprosima::fastdds::dds::DataWriter*,
                              const eprosima::fastdds::dds::PublicationMatchedStatus& status) override {
    std::lock_guard<std::mutex> lock(matched_mutex_);
    const std::string participant = ParticipantIdOf(status.last_subscription_handle);
    if (status.current_count_change > 0) ++matched_readers_[participant];
    if (status.current_count_change < 0 && --matched_readers_[participant] <= 0)
      matched_readers_.erase(participant);
    matched_.store(status.current_count);
    matched_cv_.notify_all();
  }

  Participant& participant_;
  const std::string topic_name_;
  const std::string qos_class_;
  const std::string flow_controller_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  bool latched_ = false;  // transient-local or more durable: the last sample is kept for a rebuild
  std::atomic<int> matched_{0};
  mutable std::mutex matched_mutex_;
  mutable std::condition_variable matched_cv_;  // notified on every match change
  std::map<std::string, int> matched_readers_;  // ParticipantIdOf -> matched readers of that participant
  std::mutex held_mutex_;
  std::vector<Msg> held_;    // written during a rebuild, published after it
  std::optional<Msg> last_;  // the last sample written, when latched_
  std::atomic<std::uint64_t> bytes_written_{0};
  std::atomic<std::uint64_t> samples_written_{0};
};

/// Typed reader for a fastddsgen type, calling `on_sample` on the DDS listener thread for each valid sample
/// and `on_liveliness` when a matched writer's liveliness changes. QoS from "<qos_class>.reader".
/// Callbacks must be thread-safe with respect to the owner's state.
template <class PubSubT>
class Reader : private eprosima::fastdds::dds::DataReaderListener, private ParticipantEndpoint {
 public:
  using Msg = typename PubSubT::type;
  using SampleCallback = std::function<void(const Msg&, const eprosima::fastdds::dds::SampleInfo&)>;
  using LivelinessCallback = std::function<void(const eprosima::fastdds::dds::LivelinessChangedStatus&)>;

  /// @throws DdsError when the profile is missing or the reader cannot be created.
  Reader(Participant& participant, const std::string& topic_name, const std::string& qos_class,
         SampleCallback on_sample, LivelinessCallback on_liveliness = nullptr)
      : participant_(participant),
        topic_name_(topic_name),
        qos_class_(qos_class),
        on_sample_(std::move(on_sample)),
        on_liveliness_(std::move(on_liveliness)) {
    std::shared_lock<std::shared_mutex> lock(participant_.entities_mutex_);
    CreateEntity();
    participant_.Register(this);
  }
  ~Reader() override {
    participant_.Unregister(this);
    std::shared_lock<std::shared_mutex> lock(participant_.entities_mutex_);
    DeleteEntity();
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  int matched() const { return matched_.load(); }

  /// Waits until at least `count` writers matched; false on timeout.
  bool WaitForMatched(int count, std::chrono::milliseconds timeout) const {
    return WaitForCount(matched_, count, timeout);
  }

  /// The current DDS reader (another after a Participant::Rebuild).
  eprosima::fastdds::dds::DataReader* get() const { return reader_; }

 private:
  void CreateEntity() override {
    const eprosima::fastdds::dds::DataReaderQos qos = participant_.ReaderQos(qos_class_ + ".reader");
    auto* topic = participant_.GetTopic(
        topic_name_, eprosima::fastdds::dds::TypeSupport(new KeySafePubSubType<PubSubT>()));
    reader_ = participant_.subscriber()->create_datareader(topic, qos, this);
    if (reader_ == nullptr) {
      throw DdsError("cannot create reader on topic '" + topic_name_ + "' with QoS profile '" + qos_class_ +
                     ".reader' from " + participant_.options().profiles_file + participant_.SecurityHint());
    }
  }
  void DeleteEntity() override {
    if (reader_ == nullptr) return;
    reader_->set_listener(nullptr);
    participant_.subscriber()->delete_datareader(reader_);
    reader_ = nullptr;
    matched_.store(0);
  }
  void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
    Msg msg;
    eprosima::fastdds::dds::SampleInfo info;
    while (reader->take_next_sample(&msg, &info) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK) {
      if (info.valid_data && on_sample_) on_sample_(msg, info);
    }
  }
  void on_liveliness_changed(eprosima::fastdds::dds::DataReader*,
                             const eprosima::fastdds::dds::LivelinessChangedStatus& status) override {
    if (on_liveliness_) on_liveliness_(status);
  }
  void on_subscription_matched(eprosima::fastdds::dds::DataReader*,
                               const eprosima::fastdds::dds::SubscriptionMatchedStatus& status) override {
    matched_.store(status.current_count);
  }

  Participant& participant_;
  const std::string topic_name_;
  const std::string qos_class_;
  SampleCallback on_sample_;
  LivelinessCallback on_liveliness_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  std::atomic<int> matched_{0};
};

}  // namespace cairn::core
