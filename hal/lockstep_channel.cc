#include "hal/lockstep_channel.h"

#include "hal/protocol.h"

namespace hyq::hal {

LockstepChannel::LockstepChannel(std::unique_ptr<CanChannel> inner)
    : inner_(std::move(inner)) {
  buffer_.resize(kBufferFrames);
}

CanStatus LockstepChannel::Send(std::span<const CanFrame> frames,
                                     std::size_t* sent) noexcept {
  return inner_->Send(frames, sent);
}

CanStatus LockstepChannel::Receive(std::span<CanFrame> out,
                                        std::size_t* received) noexcept {
  std::size_t n = 0;
  while (n < out.size() && head_ < tail_) out[n++] = buffer_[head_++];
  if (head_ == tail_) {
    head_ = tail_ = 0;
    tpdos_ = 0;
    tpdo_nodes_.reset();
  }
  std::size_t more = 0;
  const CanStatus st = inner_->Receive(out.subspan(n), &more);
  *received = n + more;
  return st;
}

int LockstepChannel::Pump() noexcept {
  if (tail_ < buffer_.size()) {
    std::size_t n = 0;
    (void)inner_->Receive(std::span(buffer_).subspan(tail_), &n);
    for (std::size_t i = tail_; i < tail_ + n; ++i)
      if (!buffer_[i].is_extended() && !buffer_[i].is_error() &&
          (buffer_[i].id & 0x780u) == cob::kTpdo1) {
        ++tpdos_;
        tpdo_nodes_.set(buffer_[i].id & 0x7fu);
      }
    tail_ += n;
  }
  return tpdos_;
}

}  // namespace hyq::hal
