// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// AnyParams: the parameters of a scenario's plant or built-in ECU, of whatever type its vehicle
// kind defines (hil/kinds/<kind>.cpp). The scenario does not list the kinds' types, so that a new
// kind is one file and its build line, and hil/config/ does not include every plant header.
// A value type: copying a Scenario copies its parameters (never shared). Start-up only: get<T>()
// compares type ids; the step loop holds the plant, built from the parameters once.

#include <memory>
#include <type_traits>
#include <typeinfo>
#include <utility>

namespace ehpt::hil {

class AnyParams {
 public:
  AnyParams() = default;
  AnyParams(const AnyParams& o) : value_(o.value_ ? o.value_->clone() : nullptr) {}
  AnyParams(AnyParams&&) noexcept = default;
  AnyParams& operator=(const AnyParams& o) {
    if (this != &o) value_ = o.value_ ? o.value_->clone() : nullptr;
    return *this;
  }
  AnyParams& operator=(AnyParams&&) noexcept = default;

  // out.plant = std::move(params): holds a T from now on
  template <class T>
    requires(!std::is_same_v<std::decay_t<T>, AnyParams>)
  AnyParams& operator=(T&& value) {
    value_ = std::make_unique<Holder<std::decay_t<T>>>(std::forward<T>(value));
    return *this;
  }

  bool empty() const { return value_ == nullptr; }
  // the held type (typeid(void) when empty)
  const std::type_info& type() const { return value_ ? value_->type() : typeid(void); }

  template <class T>
  bool holds() const {
    return value_ != nullptr && value_->type() == typeid(T);
  }
  template <class T>
  const T* get_if() const {
    return holds<T>() ? &static_cast<const Holder<T>*>(value_.get())->value : nullptr;
  }
  template <class T>
  T* get_if() {
    return holds<T>() ? &static_cast<Holder<T>*>(value_.get())->value : nullptr;
  }
  // the held T; std::bad_cast if it holds another type (a caller that asked the wrong kind)
  template <class T>
  const T& get() const {
    if (const T* p = get_if<T>()) return *p;
    throw std::bad_cast();
  }
  template <class T>
  T& get() {
    if (T* p = get_if<T>()) return *p;
    throw std::bad_cast();
  }

 private:
  struct HolderBase {
    virtual ~HolderBase() = default;
    virtual std::unique_ptr<HolderBase> clone() const = 0;
    virtual const std::type_info& type() const = 0;
  };
  template <class T>
  struct Holder final : HolderBase {
    template <class U>
    explicit Holder(U&& v) : value(std::forward<U>(v)) {}
    std::unique_ptr<HolderBase> clone() const override { return std::make_unique<Holder>(value); }
    const std::type_info& type() const override { return typeid(T); }
    T value;
  };
  std::unique_ptr<HolderBase> value_;
};

}  // namespace ehpt::hil
